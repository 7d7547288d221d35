// examples/common/checkpoint.hpp: --checkpoint SECONDS / --resume for the examples' long renders.
// The render driver (grainlight/integrators/render.hpp) does the work; this maps the command line
// onto grainlight::CheckpointOptions: the file lives in --out, its key is the fingerprint of every
// argument that changes the image (all but --out, --threads, --checkpoint, --resume), so a
// checkpoint of another configuration is refused with a message instead of being mixed in.
// Test hook: GRAINLIGHT_ABORT_AFTER_CHECKPOINTS=N ends the process right after the N-th write
// (exit code 86), as a crash would; ctest uses it besides a real SIGKILL.
#pragma once

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "common/cli.hpp"
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

}  // namespace gl_examples
