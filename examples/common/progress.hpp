// examples/common/progress.hpp: a one-line progress bar on stderr (thread-safe, throttled).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>
#include <unistd.h>

namespace gl_examples {

class ProgressBar {
public:
    /// A bar of `total` units; a `quiet` bar counts but never draws.
    ProgressBar(std::string label, std::uint64_t total, bool quiet = false)
        : label_(std::move(label)), total_(total ? total : 1), start_(clock::now()), tty_(isatty(2)), quiet_(quiet) {}
    ~ProgressBar() { done(); }

    /// A quiet bar counts but never draws (e.g. on every MPI rank but the first).
    ProgressBar& quiet(bool q = true) {
        quiet_ = q;
        return *this;
    }
    /// Add `n` finished units (any thread).
    void advance(std::uint64_t n = 1) {
        const auto cur = done_.fetch_add(n) + n;
        const auto now = clock::now();
        std::unique_lock lock(mutex_, std::try_to_lock);
        if (!lock.owns_lock() || quiet_) return;
        if (now - last_ < std::chrono::milliseconds(tty_ ? 100 : 2000) && cur < total_) return;
        last_ = now;
        draw(cur);
    }
    void done() {
        if (finished_.exchange(true) || quiet_) return;
        draw(total_);
        std::fputc('\n', stderr);
    }
    [[nodiscard]] double seconds() const {
        return std::chrono::duration<double>(clock::now() - start_).count();
    }

private:
    using clock = std::chrono::steady_clock;
    void draw(std::uint64_t cur) {
        if (cur > total_) cur = total_;
        const double f = double(cur) / double(total_);
        const int width = 30, filled = int(f * width);
        std::string bar(filled, '#');
        bar.resize(width, '-');
        const double el = seconds();
        const double eta = f > 0 ? el * (1 - f) / f : 0;
        std::fprintf(stderr, "%s%s [%s] %5.1f%% %6.1fs eta %5.1fs", tty_ ? "\r" : "", label_.c_str(), bar.c_str(),
                     100 * f, el, eta);
        if (!tty_) std::fputc('\n', stderr);
        std::fflush(stderr);
    }
    std::string label_;
    std::uint64_t total_;
    std::atomic<std::uint64_t> done_{0};
    std::atomic<bool> finished_{false};
    clock::time_point start_, last_{};
    std::mutex mutex_;
    bool tty_;
    bool quiet_ = false;
};

}  // namespace gl_examples
