// sylva/core/progress.hpp -- a thread-safe progress bar that appears only for work over a second.
#ifndef SYLVA_CORE_PROGRESS_HPP
#define SYLVA_CORE_PROGRESS_HPP

#include <chrono>
#include <cstdio>
#include <mutex>
#include <string>

namespace sylva {

/// Prints "label [#####.....] 42%" to a stream (stderr by default) once the work has run for
/// `delay`, redrawing at most ten times a second. Safe to call from several threads.
class ProgressBar {
public:
    explicit ProgressBar(std::string label, std::FILE* out = stderr,
                         std::chrono::milliseconds delay = std::chrono::milliseconds(1000))
        : label_(std::move(label)), out_(out), delay_(delay), start_(Clock::now()) {}
    ProgressBar(const ProgressBar&) = delete;
    ProgressBar& operator=(const ProgressBar&) = delete;
    ~ProgressBar() { finish(); }

    /// Reports that `fraction` (0..1) of the work is done.
    void update(double fraction) {
        std::lock_guard lock(mutex_);
        auto now = Clock::now();
        if (finished_ || now - start_ < delay_ || now - last_draw_ < std::chrono::milliseconds(100)) return;
        last_draw_ = now;
        draw(fraction);
    }
    /// Completes the bar (prints 100% if it was ever shown).
    void finish() {
        std::lock_guard lock(mutex_);
        if (finished_) return;
        finished_ = true;
        if (shown_) {
            draw(1.0);
            std::fputc('\n', out_);
        }
    }
    [[nodiscard]] bool shown() const { return shown_; }

private:
    using Clock = std::chrono::steady_clock;
    void draw(double fraction) {
        constexpr int width = 30;
        int filled = static_cast<int>(fraction * width + 0.5);
        std::string bar(static_cast<std::size_t>(width), '.');
        for (int i = 0; i < filled && i < width; ++i) bar[static_cast<std::size_t>(i)] = '#';
        std::fprintf(out_, "\r%s [%s] %3d%%", label_.c_str(), bar.c_str(), static_cast<int>(fraction * 100.0 + 0.5));
        std::fflush(out_);
        shown_ = true;
    }
    std::string label_;
    std::FILE* out_;
    std::chrono::milliseconds delay_;
    Clock::time_point start_;
    Clock::time_point last_draw_{};
    std::mutex mutex_;
    bool shown_ = false;
    bool finished_ = false;
};

}  // namespace sylva

#endif  // SYLVA_CORE_PROGRESS_HPP
