/// @file grainlight/core/error.hpp
/// Error types and the construction-time validation helpers.
///
/// Policy (DESIGN "Errors and bad input"): parameters are validated once, where a user constructs
/// a thing or loads it from disk. Messages name the function, the parameter, its value and the
/// valid range. Kernels never throw; they assume validated input (GRAINLIGHT_DCHECK).
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>

namespace grainlight {

/// A parameter outside its valid range (negative sigma_t, albedo > 1, |g| >= 1, ...).
class invalid_argument : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

/// A file that is truncated, corrupted, of the wrong version or otherwise not what it claims.
class format_error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// A file or stream that cannot be opened, read or written.
class io_error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

namespace detail {
template <class T>
std::string to_display(const T& v) {
    std::ostringstream os;
    os.precision(9);
    os << v;
    return os.str();
}
}  // namespace detail

/// Throw grainlight::invalid_argument with the standard message
/// "<where>: <param> = <value> is invalid; valid range: <range>".
template <class T>
[[noreturn]] inline void raise_invalid_argument(std::string_view where, std::string_view param, const T& value,
                                                std::string_view range) {
    std::string msg;
    msg.append(where).append(": ").append(param).append(" = ").append(detail::to_display(value));
    msg.append(" is invalid; valid range: ").append(range);
#if defined(__cpp_exceptions) || defined(__EXCEPTIONS)
    throw invalid_argument(msg);
#else
    // -fno-exceptions builds (device code, some engines): report and stop.
    std::fputs(("grainlight: " + msg + "\n").c_str(), stderr);
    std::abort();
#endif
}

/// Throw an error of type E (grainlight::format_error, io_error, ...) with `msg`; in builds
/// without exceptions print it and abort. Library code raises through this (or
/// raise_invalid_argument) instead of writing `throw`, so every header compiles with
/// -fno-exceptions.
template <class E>
[[noreturn]] inline void raise_error(const std::string& msg) {
#if defined(__cpp_exceptions) || defined(__EXCEPTIONS)
    throw E(msg);
#else
    std::fputs(("grainlight: " + msg + "\n").c_str(), stderr);
    std::abort();
#endif
}

/// Exceptions are enabled in this translation unit.
#if defined(__cpp_exceptions) || defined(__EXCEPTIONS)
#define GRAINLIGHT_HAS_EXCEPTIONS 1
#else
#define GRAINLIGHT_HAS_EXCEPTIONS 0
#endif

/// Validate `cond`; on failure raise_invalid_argument. NaN values fail every range check because
/// callers phrase conditions positively (`x >= 0`, not `!(x < 0)`).
template <class T>
inline void check_argument(bool cond, std::string_view where, std::string_view param, const T& value,
                           std::string_view range) {
    if (!cond) raise_invalid_argument(where, param, value, range);
}

/// Convenience: value must be finite.
template <class T>
inline void check_finite(std::string_view where, std::string_view param, T value) {
    check_argument(std::isfinite(static_cast<double>(value)), where, param, value, "finite");
}

}  // namespace grainlight
