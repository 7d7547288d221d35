// examples/common/checkpoint.hpp: --checkpoint SECONDS / --resume for the examples' long renders.
// The render driver (grainlight/integrators/render.hpp) does the work; this maps the command line
// onto grainlight::CheckpointOptions: the file lives in --out, its key is the fingerprint of every
// argument that changes the image (all but --out, --threads, --checkpoint, --resume), so a
// checkpoint of another configuration is refused with a message instead of being mixed in.
// Test hook: GRAINLIGHT_ABORT_AFTER_CHECKPOINTS=N ends the process right after the N-th write
// (exit code 86), as a crash would; ctest uses it besides a real SIGKILL. Choices a run takes from
// its own timings (a preview's P_a, an equal-time sample count) go through `decided`: kept beside
// the checkpoints for --resume, taken by rank 0 and sent to every MPI rank.
#pragma once

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <filesystem>
#include <functional>
#include <string>
#include <system_error>
#include <vector>

#include "common/cli.hpp"
#include "common/harness.hpp"
#include "common/output.hpp"
#include "grainlight/integrators/render.hpp"

namespace gl_examples {

/// Checkpoint options from --checkpoint / --resume (disabled when neither is given).
inline grainlight::CheckpointOptions checkpoint_from_cli(const Cli& cli, const std::filesystem::path& file) {
    grainlight::CheckpointOptions c;
    if (!cli.has("checkpoint") && !cli.has("resume")) return c;
    c.path = file;
    c.interval_seconds = cli.num("checkpoint", 60.0);
    if (!(c.interval_seconds >= 0.0) || !std::isfinite(c.interval_seconds))
        throw cli_error("--checkpoint = " + cli.str("checkpoint") + " must be a finite number of seconds >= 0");
    if (cli.has("resume") && !cli.str("resume").empty())
        throw cli_error("--resume takes no value (got '" + cli.str("resume") + "')");
    c.resume = cli.has("resume");
    c.key = cli.fingerprint({"out", "threads", "checkpoint", "resume"});
    if (const char* n = std::getenv("GRAINLIGHT_ABORT_AFTER_CHECKPOINTS")) c.abort_after_writes = std::atoi(n);
    return c;
}

/// The checkpoint of one labelled render: the file DIR/<example>.<stem><tag>.checkpoint with a
/// file-name-safe stem made from `label`, its key the run's fingerprint mixed with the stem (each
/// render of an example has its own key), kept when its render finishes (a resumed multi-render run
/// skips the renders already done). Disabled (empty path) without --checkpoint / --resume.
inline grainlight::CheckpointOptions checkpoint_file(const Cli& cli, const std::filesystem::path& dir,
                                                     const std::string& example, const std::string& label,
                                                     const std::string& tag = "") {
    std::string stem = label;
    for (char& ch : stem)
        if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '.') ch = '_';
    auto c = checkpoint_from_cli(cli, dir / (example + "." + stem + tag + ".checkpoint"));
    if (!c.path.empty()) {
        c.key ^= std::hash<std::string>{}(stem);
        c.remove_when_done = false;
    }
    return c;
}

/// The checkpoint of one render of a harness example: DIR/<example>.<stem>[.rankRofK].checkpoint
/// in --out (disabled without --checkpoint / --resume). The file is kept when the render finishes
/// (so a resumed multi-render run skips the renders already done) and removed by ex.finish().
inline grainlight::CheckpointOptions checkpoint_for(const Example& ex, const std::string& stem) {
    const std::string rank_tag =
        ex.ranks() > 1 ? ".rank" + std::to_string(ex.rank()) + "of" + std::to_string(ex.ranks()) : "";
    auto c = checkpoint_file(ex.cli(), ex.out(), ex.name(), stem, rank_tag);
    if (!c.path.empty()) ex.track_checkpoint(c.path);
    return c;
}

/// Values a run decides from its own timings (a timed preview's P_a, an equal-time sample count):
/// rank 0 calls `decide()` and every rank gets its values (MpiSession::broadcast), so all ranks
/// render the same image. With --checkpoint / --resume rank 0 also keeps them in --out as
/// <example>.<stem>.decision (atomic write; key = the run's fingerprint mixed with the stem), and
/// --resume reads them back instead of deciding again, so a resumed run renders exactly what the
/// killed run would have (its checkpoints were made with these values). ex.finish() removes it.
template <class Decide>
std::vector<double> decided(const Example& ex, const std::string& stem, Decide&& decide) {
    std::string safe = stem;
    for (char& ch : safe)
        if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '.') ch = '_';
    const grainlight::CheckpointOptions c = checkpoint_from_cli(ex.cli(), ex.out() / (ex.name() + "." + safe + ".decision"));
    const std::uint64_t key = c.key ^ std::hash<std::string>{}(safe);
    std::vector<double> v;
    std::string failure;  // rank 0's error: every rank must leave the broadcast and fail alike
    if (ex.root()) try {
        bool loaded = false;
        if (!c.path.empty() && c.resume && std::filesystem::exists(c.path)) {
            std::ifstream in(c.path);
            std::string magic, hex;
            unsigned long long k = 0;
            std::size_t n = 0;
            if (!(in >> magic >> k >> n) || magic != "grainlight-decision")
                throw cli_error("--resume: '" + c.path.string() + "' is not a decision file; delete it or run without --resume");
            if (k != key)
                throw cli_error("--resume: '" + c.path.string() +
                                "' was written by a run with other arguments; delete it or run without --resume");
            for (std::size_t i = 0; i < n && in >> hex; ++i) v.push_back(std::strtod(hex.c_str(), nullptr));
            if (v.size() != n) throw cli_error("--resume: '" + c.path.string() + "' is truncated; delete it");
            loaded = true;
        }
        if (!loaded) {
            v = decide();
            if (!c.path.empty()) {
                std::string text = "grainlight-decision " + std::to_string(key) + " " + std::to_string(v.size());
                char buf[64];
                for (double x : v) {
                    std::snprintf(buf, sizeof buf, " %a", x);  // hexadecimal: exact
                    text += buf;
                }
                write_text_atomic(c.path, text + "\n");
            }
        }
    } catch (const std::exception& e) {
        failure = e.what();
    }
    v.insert(v.begin(), failure.empty() ? 0.0 : 1.0);  // status first
    ex.mpi().broadcast(v);
    // Under mpirun the harness aborts every rank while the exception unwinds, before its message is
    // printed: rank 0 says why first.
    if (v.front() != 0.0 && ex.root() && ex.ranks() > 1) std::fprintf(stderr, "%s: error: %s\n", ex.name().c_str(), failure.c_str());
    if (v.front() != 0.0) throw cli_error(failure.empty() ? "rank 0 failed to decide '" + safe + "' (its message above)" : failure);
    v.erase(v.begin());
    if (!c.path.empty()) ex.track_checkpoint(c.path);
    return v;
}

/// RenderOptions of one render of a harness example: spp, the example's seed and threads, this
/// rank's row share, and its checkpoint (checkpoint_for).
inline grainlight::RenderOptions render_options(const Example& ex, int spp, const std::string& stem) {
    grainlight::RenderOptions o;
    o.spp = spp;
    o.seed = ex.seed();
    o.threads = ex.threads();
    o.row_offset = ex.rank();
    o.row_stride = ex.ranks();
    o.checkpoint = checkpoint_for(ex, stem);
    return o;
}

}  // namespace gl_examples
