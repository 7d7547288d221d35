// Where the tests' reference data (tests/data/, each file names its source) is: the environment
// variable GRAINLIGHT_TEST_DATA_DIR, which ctest sets for every test binary (tests/CMakeLists.txt),
// else tests/data relative to the working directory (a binary run by hand from the source root).
// Taken at run time rather than compiled in, so no test's compile line holds an absolute path.
#pragma once

#include <cstdlib>
#include <string>

namespace grainlight_test {

/// The reference-data directory (no trailing slash).
inline std::string data_dir() {
    if (const char* e = std::getenv("GRAINLIGHT_TEST_DATA_DIR"); e && *e) return e;
    return "tests/data";
}

}  // namespace grainlight_test
