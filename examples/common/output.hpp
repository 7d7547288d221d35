// examples/common/output.hpp: JSON summary lines, CSV files (written atomically) and PNG plots
// drawn by Debian's matplotlib (/usr/bin/python3; the python3 on PATH may be another one).
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "grainlight/core/serialization.hpp"

namespace gl_examples {

/// One JSON object built field by field; str() gives a single line.
class Json {
public:
    Json& num(const std::string& key, double v) {
        std::ostringstream os;
        if (std::isfinite(v)) {
            os << std::setprecision(10) << v;
        } else {
            os << "null";
        }
        return raw(key, os.str());
    }
    Json& integer(const std::string& key, long long v) { return raw(key, std::to_string(v)); }
    Json& str(const std::string& key, const std::string& v) { return raw(key, quote(v)); }
    Json& boolean(const std::string& key, bool v) { return raw(key, v ? "true" : "false"); }
    Json& nums(const std::string& key, const std::vector<double>& v) {
        std::ostringstream os;
        os << "[" << std::setprecision(10);
        for (std::size_t i = 0; i < v.size(); ++i) {  // non-finite -> null, as in num(): never a silent 0
            os << (i ? "," : "");
            if (std::isfinite(v[i]))
                os << v[i];
            else
                os << "null";
        }
        os << "]";
        return raw(key, os.str());
    }
    Json& raw(const std::string& key, const std::string& json_value) {
        if (!body_.empty()) body_ += ',';
        body_ += quote(key);
        body_ += ':';
        body_ += json_value;
        return *this;
    }
    [[nodiscard]] std::string str() const { return "{" + body_ + "}"; }
    static std::string quote(const std::string& s) {
        std::string o = "\"";
        for (char c : s) {
            if (c == '"' || c == '\\') o += '\\';
            if (c == '\n') {
                o += "\\n";
                continue;
            }
            o += c;
        }
        return o + "\"";
    }

private:
    std::string body_;
};

/// Write `text` to `path` atomically (temporary file + rename: grainlight::write_file_atomic).
inline void write_text_atomic(const std::filesystem::path& path, const std::string& text) {
    grainlight::write_file_atomic(path, text.data(), text.size());
}

/// A CSV table: header + rows of numbers (or strings).
class Csv {
public:
    explicit Csv(std::vector<std::string> header) : header_(std::move(header)) {}
    Csv& row(const std::vector<double>& values) {
        std::ostringstream os;
        os << std::setprecision(9);
        for (std::size_t i = 0; i < values.size(); ++i) os << (i ? "," : "") << values[i];
        rows_.push_back(os.str());
        return *this;
    }
    Csv& row_text(const std::vector<std::string>& values) {
        std::string s;
        for (std::size_t i = 0; i < values.size(); ++i) s += (i ? "," : "") + values[i];
        rows_.push_back(s);
        return *this;
    }
    void write(const std::filesystem::path& path) const {
        std::string text;
        for (std::size_t i = 0; i < header_.size(); ++i) text += (i ? "," : "") + header_[i];
        text += "\n";
        for (auto& r : rows_) text += r + "\n";
        write_text_atomic(path, text);
    }

private:
    std::vector<std::string> header_;
    std::vector<std::string> rows_;
};

}  // namespace gl_examples
