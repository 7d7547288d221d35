// examples/common/cli.hpp: the command-line convention every example shares (DESIGN):
//   --quality quick|full   --out DIR   --seed S   --threads N
// plus typed per-program options. Bad arguments: message naming the argument, exit code 2.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace gl_examples {

/// Thrown for a bad command line; main() prints it and exits with status 2.
struct cli_error : std::runtime_error {
    using std::runtime_error::runtime_error;
};

class Cli {
public:
    Cli(int argc, char** argv, std::string program, std::string summary)
        : program_(std::move(program)), summary_(std::move(summary)) {
        for (int i = 1; i < argc; ++i) {
            std::string a = argv[i];
            if (a == "-h" || a == "--help") {
                help_ = true;
                continue;
            }
            if (a.rfind("--", 0) != 0) throw cli_error("unexpected argument '" + a + "' (options start with --)");
            std::string key = a.substr(2), value;
            if (auto eq = key.find('='); eq != std::string::npos) {
                value = key.substr(eq + 1);
                key = key.substr(0, eq);
            } else if (i + 1 < argc && std::string(argv[i + 1]).rfind("--", 0) != 0) {
                value = argv[++i];
            } else {
                value = "";  // a flag
            }
            if (args_.count(key)) throw cli_error("argument --" + key + " given twice");
            args_[key] = value;
        }
    }

    /// Document an option (for --help) and mark it known.
    Cli& option(const std::string& name, const std::string& help, const std::string& def = "") {
        known_.insert(name);
        help_lines_.push_back("  --" + name + (def.empty() ? "" : " (default " + def + ")") + "\n      " + help);
        return *this;
    }
    /// The shared options.
    Cli& common_options(const std::string& default_out = "out") {
        option("quality", "quick | full", "quick");
        option("out", "output directory", default_out);
        option("seed", "random seed (unsigned integer)", "1");
        option("threads", "worker threads (0 = all cores)", "0");
        return *this;
    }
    /// The options of resumable renders: --checkpoint SECONDS and --resume (see checkpoint.hpp).
    Cli& checkpoint_options() {
        option("checkpoint", "write the render's state to --out every SECONDS (resumable with --resume)");
        option("resume", "continue from the checkpoint in --out (a fresh render when there is none)");
        return *this;
    }
    /// A 64-bit fingerprint (FNV-1a) of the program name and every argument given except `ignore`
    /// (options that do not change the result: output directory, threads, checkpointing).
    [[nodiscard]] std::uint64_t fingerprint(const std::set<std::string>& ignore) const {
        std::uint64_t h = 0xcbf29ce484222325ull;
        auto mix = [&](const std::string& s) {
            for (unsigned char c : s) h = (h ^ c) * 0x100000001b3ull;
            h = (h ^ 0xffu) * 0x100000001b3ull;  // separator
        };
        mix(program_);
        for (const auto& [k, v] : args_)  // std::map: sorted, so the order of arguments does not matter
            if (!ignore.count(k)) {
                mix(k);
                mix(v);
            }
        return h;
    }
    /// Call after declaring options: prints help and exits, or rejects unknown options.
    void finish() {
        if (help_) {
            std::cout << program_ << ": " << summary_ << "\n\noptions:\n";
            for (auto& l : help_lines_) std::cout << l << "\n";
            std::exit(0);
        }
        for (auto& [k, v] : args_)
            if (!known_.count(k)) throw cli_error("unknown argument --" + k + " (see --help)");
    }

    [[nodiscard]] bool has(const std::string& name) const { return args_.count(name) > 0; }
    [[nodiscard]] std::string str(const std::string& name, const std::string& def = "") const {
        auto it = args_.find(name);
        return it == args_.end() ? def : it->second;
    }
    [[nodiscard]] double num(const std::string& name, double def) const {
        auto it = args_.find(name);
        if (it == args_.end()) return def;
        return parse_double(name, it->second);
    }
    /// A required number.
    [[nodiscard]] double num(const std::string& name) const {
        auto it = args_.find(name);
        if (it == args_.end()) throw cli_error("missing required argument --" + name);
        return parse_double(name, it->second);
    }
    [[nodiscard]] std::uint64_t integer(const std::string& name, std::uint64_t def) const {
        auto it = args_.find(name);
        if (it == args_.end()) return def;
        const std::string& s = it->second;
        if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos)
            throw cli_error("--" + name + " = '" + s + "' is not a non-negative integer");
        try {
            return std::stoull(s);
        } catch (...) {
            throw cli_error("--" + name + " = '" + s + "' is out of range");
        }
    }
    /// Comma-separated list of numbers.
    [[nodiscard]] std::vector<double> list(const std::string& name, std::vector<double> def) const {
        auto it = args_.find(name);
        if (it == args_.end()) return def;
        std::vector<double> out;
        std::stringstream ss(it->second);
        std::string item;
        while (std::getline(ss, item, ',')) out.push_back(parse_double(name, item));
        if (out.empty()) throw cli_error("--" + name + " needs at least one value");
        return out;
    }

    // Shared options, validated.
    [[nodiscard]] bool full_quality() const {
        const std::string q = str("quality", "quick");
        if (q != "quick" && q != "full") throw cli_error("--quality = '" + q + "' must be quick or full");
        return q == "full";
    }
    [[nodiscard]] std::filesystem::path out_dir(const std::string& def = "out") const {
        std::filesystem::path p = str("out", def);
        std::error_code ec;
        std::filesystem::create_directories(p, ec);
        if (ec) throw cli_error("--out = '" + p.string() + "' cannot be created: " + ec.message());
        return p;
    }
    [[nodiscard]] std::uint64_t seed() const { return integer("seed", 1); }
    /// Applies --threads to OpenMP and returns the thread count in use.
    int threads() const {
        const auto n = integer("threads", 0);
#if defined(_OPENMP)
        if (n > 0) omp_set_num_threads(int(n));
        return n > 0 ? int(n) : omp_get_max_threads();
#else
        return n > 0 ? int(n) : 1;
#endif
    }

private:
    static double parse_double(const std::string& name, const std::string& s) {
        if (s == "inf" || s == "infinity") return std::numeric_limits<double>::infinity();
        char* end = nullptr;
        const double v = std::strtod(s.c_str(), &end);
        if (s.empty() || end != s.c_str() + s.size())
            throw cli_error("--" + name + " = '" + s + "' is not a number");
        return v;
    }
    std::string program_, summary_;
    std::map<std::string, std::string> args_;
    std::set<std::string> known_;
    std::vector<std::string> help_lines_;
    bool help_ = false;
};

/// Run `body` and turn exceptions into a message + exit status (2: bad arguments, 1: failure).
template <class Body>
int run_main(const char* program, Body&& body) {
    try {
        return body();
    } catch (const cli_error& e) {
        std::cerr << program << ": error: " << e.what() << "\n";
        return 2;
    } catch (const std::invalid_argument& e) {
        std::cerr << program << ": invalid argument: " << e.what() << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << program << ": error: " << e.what() << "\n";
        return 1;
    }
}

}  // namespace gl_examples
