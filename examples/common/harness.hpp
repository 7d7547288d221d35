// examples/common/harness.hpp: the one example harness. An `Example` owns the shared command
// line (--quality quick|full, --out DIR, --seed S, --threads N), typed options that declare,
// default and parse in one line, the progress bar, the blocked-parallel loop with its ordered
// reduction (core/parallel.hpp), CSV files, plots drawn by real .py scripts under
// examples/plots/, and the JSON summary (the last stdout line) pre-filled with what reproduces
// the run: example, version, commit, command line, quality, seed, threads and ranks.
//
// It is the single place where work splitting over processes, checkpoints and NaN counting plug
// in: examples that use `parallel` get them without per-example code.
//   - MPI (examples/common/mpi.hpp; compiled in for the examples CMake links with MPI): the
//     Example owns the MPI session; `rank()`, `ranks()`, `root()`; `mpi()` for the gathers; only
//     rank 0 draws progress bars and prints the summary (`finish`), and the summary's "ranks" is
//     the real count.
//   - Checkpoints: `checkpointable()` declares --checkpoint SECONDS / --resume; after ready(),
//     examples/common/checkpoint.hpp's `checkpoint_for(ex, "stem")` gives the RenderOptions
//     checkpoint of one render (per-rank file in --out, key = fingerprint of the arguments that
//     change the image); finish() removes the checkpoints of a completed run.
//   - Non-finite samples: renders count them in their films; `nonfinite(j, count)` reports them.
//
//   int main(int argc, char** argv) {
//       return gl_examples::run(argc, argv, "name", "what it reproduces", [&](gl_examples::Example& ex) {
//           const auto paths = ex.opt<std::uint64_t>("paths", 200000, 2000000, "photon paths");
//           ex.ready();
//           ...
//           return ex.finish(ex.summary().num("R", r));
//       });
//   }
#pragma once

#include <cstdint>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "common/cli.hpp"
#include "common/mpi.hpp"
#include "common/output.hpp"
#include "common/progress.hpp"
#include "grainlight/core/parallel.hpp"

#if defined(GRAINLIGHT_EXAMPLE_INFO_LINKED)
// Version, commit and source directory from the generated examples/common/example_info.cpp.in
// (linked by every example target), not from compile definitions.
extern "C" {
extern const char grainlight_example_version[];
extern const char grainlight_example_commit[];
extern const char grainlight_examples_dir[];
}
#define GRAINLIGHT_VERSION_STRING grainlight_example_version
#define GRAINLIGHT_GIT_COMMIT grainlight_example_commit
#define GRAINLIGHT_EXAMPLES_DIR grainlight_examples_dir
#endif
#ifndef GRAINLIGHT_VERSION_STRING
#define GRAINLIGHT_VERSION_STRING "unknown"
#endif
#ifndef GRAINLIGHT_GIT_COMMIT
#define GRAINLIGHT_GIT_COMMIT "unknown"
#endif
#ifndef GRAINLIGHT_EXAMPLES_DIR
#define GRAINLIGHT_EXAMPLES_DIR "."
#endif

namespace gl_examples {

/// How an example documents --out on --help: its default ("" = none shown) and its help text.
struct OutOption {
    std::string default_out;                ///< default of --out ("" for none)
    std::string help = "output directory";  ///< help line of --out
};

class Example {
public:
    Example(int argc, char** argv, std::string program, std::string summary)
        : Example(argc, argv, std::move(program), std::move(summary), "out") {}
    /// As above with another default for --out (e.g. "out/<example>").
    Example(int argc, char** argv, std::string program, std::string summary, std::string default_out)
        : mpi_(argc, argv), cli_(argc, argv, program, std::move(summary)), program_(std::move(program)),
          default_out_(std::move(default_out)) {
        for (int i = 0; i < argc; ++i) {
            if (i) command_ += ' ';
            command_ += argv[i];
        }
        cli_.common_options(default_out_);
    }
    /// As above with --out documented by `out` (e.g. an optional directory or a file).
    Example(int argc, char** argv, std::string program, std::string summary, const OutOption& out)
        : mpi_(argc, argv), cli_(argc, argv, program, std::move(summary)), program_(std::move(program)),
          default_out_(out.default_out.empty() ? "out" : out.default_out) {
        for (int i = 0; i < argc; ++i) {
            if (i) command_ += ' ';
            command_ += argv[i];
        }
        // The shared options of Cli::common_options, with this --out line.
        cli_.option("quality", "quick | full", "quick");
        cli_.option("out", out.help, out.default_out);
        cli_.option("seed", "random seed (unsigned integer)", "1");
        cli_.option("threads", "worker threads (0 = all cores)", "0");
    }

    /// A typed option with one default: declared for --help, defaulted and parsed in one line.
    template <class T>
    T opt(const std::string& name, T def, const std::string& help) {
        cli_.option(name, help, show(def));
        return get<T>(name, def);
    }
    /// A typed option whose default depends on --quality (quick, full).
    template <class T>
    T opt(const std::string& name, T quick, T full, const std::string& help) {
        cli_.option(name, help, show(quick) + " quick, " + show(full) + " full");
        return get<T>(name, full_quality() ? full : quick);
    }

    /// A typed option without a default: declared for --help, parsed when given, std::nullopt
    /// when absent (for options such as "--x or --radius-um"). `show_default` only documents.
    template <class T>
    std::optional<T> opt_optional(const std::string& name, const std::string& help,
                                  const std::string& show_default = "") {
        cli_.option(name, help, show_default);
        if (!cli_.has(name)) return std::nullopt;
        return get<T>(name, T{});
    }
    /// Whether `--name` was given on the command line.
    [[nodiscard]] bool given(const std::string& name) const { return cli_.has(name); }
    /// The text given for `--name` ("" when absent), for messages that quote the argument.
    [[nodiscard]] std::string given_text(const std::string& name) const { return cli_.str(name); }

    /// What --out names: a directory (created by ready(), default "out"), a directory written
    /// only when --out is given (created then; out() empty otherwise), or a file the example
    /// writes itself (not created; out() empty when --out is absent).
    enum class OutKind { directory, optional_directory, file };
    /// ready() with the meaning of --out; ready(OutKind::directory) is ready().
    void ready(OutKind kind) {
        if (kind == OutKind::directory) return ready();
        cli_.finish();
        full_ = cli_.full_quality();
        seed_ = cli_.seed();
        threads_ = cli_.threads();
        if (kind == OutKind::optional_directory && cli_.has("out"))
            out_ = cli_.out_dir(default_out());
        else
            out_ = cli_.str("out", "");
    }

    /// Call after the last opt(): prints --help (and exits) or rejects unknown options, then
    /// applies --threads and creates --out.
    void ready() {
        cli_.finish();
        full_ = cli_.full_quality();
        seed_ = cli_.seed();
        threads_ = cli_.threads();
        out_ = cli_.out_dir(default_out());
    }

    [[nodiscard]] bool full() const { return full_; }
    [[nodiscard]] const std::filesystem::path& out() const { return out_; }
    [[nodiscard]] std::uint64_t seed() const { return seed_; }
    [[nodiscard]] int threads() const { return threads_; }
    /// Number of MPI ranks (1 without MPI or without mpirun).
    [[nodiscard]] int ranks() const { return mpi_.size(); }
    /// This process's rank (0 without MPI).
    [[nodiscard]] int rank() const { return mpi_.rank(); }
    /// Rank 0: the process that writes outputs and prints.
    [[nodiscard]] bool root() const { return mpi_.root(); }
    /// The MPI session (gathers of films and byte buffers on rank 0).
    [[nodiscard]] const MpiSession& mpi() const { return mpi_; }
    /// Declare --checkpoint SECONDS and --resume (call before ready(); see checkpoint.hpp).
    void checkpointable() { cli_.checkpoint_options(); }
    /// Remember a checkpoint file of this run (checkpoint.hpp); finish() removes it.
    void track_checkpoint(const std::filesystem::path& p) const { checkpoints_.push_back(p); }
    /// Add "nonfinite_samples": the count of NaN / infinite samples the renders dropped.
    static Json& nonfinite(Json& j, std::uint64_t count) { return j.integer("nonfinite_samples", (long long)count); }
    [[nodiscard]] const std::string& name() const { return program_; }
    [[nodiscard]] const Cli& cli() const { return cli_; }

    /// `work(block, begin, end) -> Partial` over [0, count) in blocks of `block` items on the
    /// example's threads, merged in block order (identical results on any thread count), with a
    /// progress bar labelled `label`.
    template <class Partial, class Work, class Merge>
    Partial parallel(const std::string& label, std::uint64_t count, std::uint64_t block, Work&& work, Merge&& merge,
                     Partial init = Partial{}) const {
        ProgressBar bar(label, grainlight::block_count(count, block), !root());
        Partial p = grainlight::parallel_blocks<Partial>(
            count, block, threads_,
            [&](std::uint64_t b, std::uint64_t begin, std::uint64_t end) {
                Partial part = work(b, begin, end);
                bar.advance();
                return part;
            },
            merge, std::move(init));
        bar.done();
        return p;
    }

    /// A progress bar for work that parallel() does not run (serial stages, library callbacks).
    [[nodiscard]] ProgressBar progress(const std::string& label, std::uint64_t total) const {
        return ProgressBar(label, total, !root());
    }

    /// The JSON summary, pre-filled with what reproduces the run.
    [[nodiscard]] Json summary() const {
        Json j;
        j.str("example", program_)
            .str("version", GRAINLIGHT_VERSION_STRING)
            .str("commit", GRAINLIGHT_GIT_COMMIT)
            .str("command", command_)
            .str("quality", full_ ? "full" : "quick")
            .integer("seed", (long long)seed_)
            .integer("threads", threads_)
            .integer("ranks", ranks());
        return j;
    }
    /// Print the summary as the last stdout line (rank 0 only) and remove the checkpoints of this
    /// completed run; returns the exit status 0.
    int finish(const Json& j) const { return finish_line(j.str()); }
    /// finish() with the summary line given as text (a JSON object built by hand).
    int finish_line(const std::string& json_line) const {
        for (const auto& p : checkpoints_) {
            std::error_code ec;
            std::filesystem::remove(p, ec);
        }
        if (root()) std::cout << json_line << std::endl;
        return 0;
    }

    /// Write a CSV into --out.
    std::filesystem::path csv(const std::string& file, const Csv& table) const {
        const auto p = out_ / file;
        table.write(p);
        return p;
    }
    /// Draw `png` from `csv` with examples/plots/<script>.py (Debian's /usr/bin/python3 +
    /// matplotlib, or $GRAINLIGHT_PYTHON). Returns false with a note when matplotlib is missing:
    /// the CSV is the result, the plot a bonus.
    /// `args` are passed after CSV and PNG (numbers the plot annotates).
    bool plot(const std::string& script, const std::filesystem::path& csv_path, const std::filesystem::path& png,
              const std::vector<std::string>& args = {}) const {
        const std::filesystem::path py = std::filesystem::path(GRAINLIGHT_EXAMPLES_DIR) / "plots" / (script + ".py");
        const char* python = std::getenv("GRAINLIGHT_PYTHON");
        const std::string interp = python ? python : "/usr/bin/python3";
        std::string cmd = interp + " '" + py.string() + "' '" + csv_path.string() + "' '" + png.string() + "'";
        for (const auto& a : args) cmd += " '" + a + "'";
        cmd += " 2>&1";
        FILE* p = popen(cmd.c_str(), "r");
        if (!p) return false;
        std::string output;
        char buf[256];
        while (fgets(buf, sizeof buf, p)) output += buf;
        if (pclose(p) != 0) {
            std::cerr << "note: plot " << png << " not drawn (" << interp << " " << py << "): " << output.substr(0, 300)
                      << "\n";
            return false;
        }
        return true;
    }

private:
    std::string default_out() const { return default_out_; }
    bool full_quality() const { return cli_.full_quality(); }
    template <class T>
    static std::string show(const T& v) {
        std::ostringstream os;
        if constexpr (std::is_same_v<T, bool>)
            os << (v ? "on" : "off");
        else if constexpr (std::is_same_v<T, std::vector<double>>) {
            for (std::size_t i = 0; i < v.size(); ++i) os << (i ? "," : "") << v[i];
        } else
            os << v;
        return os.str();
    }
    template <class T>
    T get(const std::string& name, const T& def) const {
        if constexpr (std::is_same_v<T, bool>) {
            if (!cli_.has(name)) return def;
            const std::string v = cli_.str(name);
            if (v.empty() || v == "1" || v == "on" || v == "true") return true;
            if (v == "0" || v == "off" || v == "false") return false;
            throw cli_error("--" + name + " = '" + v + "' must be on or off");
        } else if constexpr (std::is_same_v<T, std::string>) {
            return cli_.str(name, def);
        } else if constexpr (std::is_same_v<T, std::vector<double>>) {
            return cli_.list(name, def);
        } else if constexpr (std::is_integral_v<T>) {
            const auto v = cli_.integer(name, std::uint64_t(def));
            if (v > std::uint64_t(std::numeric_limits<T>::max()))
                throw cli_error("--" + name + " = " + std::to_string(v) + " is out of range");
            return T(v);
        } else {
            return T(cli_.num(name, double(def)));
        }
    }
    MpiSession mpi_;  // first: MPI_Init before anything else, MPI_Finalize last
    Cli cli_;
    std::string program_, command_, default_out_ = "out";
    mutable std::vector<std::filesystem::path> checkpoints_;
    bool full_ = false;
    std::uint64_t seed_ = 1;
    int threads_ = 1;
    std::filesystem::path out_;
};

/// main() of an example: builds the Example and turns exceptions into a message and an exit
/// status (2: bad arguments, 1: failure).
template <class Body>
int run(int argc, char** argv, const char* program, const char* summary, Body&& body) {
    return run_main(program, [&]() {
        Example ex(argc, argv, program, summary);
        return body(ex);
    });
}

/// As above, with --out documented by `out` (see OutOption).
template <class Body>
int run(int argc, char** argv, const char* program, const char* summary, const OutOption& out, Body&& body) {
    return run_main(program, [&]() {
        Example ex(argc, argv, program, summary, out);
        return body(ex);
    });
}

/// As above, with another default for --out than "out".
template <class Body>
int run(int argc, char** argv, const char* program, const char* summary, const char* default_out, Body&& body) {
    return run_main(program, [&]() {
        Example ex(argc, argv, program, summary, default_out);
        return body(ex);
    });
}

}  // namespace gl_examples
