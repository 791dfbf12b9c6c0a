#include "app/progress.h"

#include <cstdio>
#include <unistd.h>

namespace calib::app {

using Clock = std::chrono::steady_clock;

Progress::Progress(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {}

pipeline::ProgressFn Progress::callback()
{
    return [this](const std::string &stage, size_t done, size_t total) { update(stage, done, total); };
}

void Progress::note(const std::string &line)
{
    if (quiet_)
        return;
    std::lock_guard<std::mutex> lock(mutex_);
    std::fprintf(stderr, "%s%s\n", tty_ ? "\r\033[K" : "", line.c_str());
}

void Progress::update(const std::string &stage, size_t done, size_t total)
{
    if (quiet_)
        return;
    std::lock_guard<std::mutex> lock(mutex_);
    const auto now = Clock::now();
    if (stage != stage_) {
        stage_ = stage;
        stage_start_ = now;
        last_print_ = now;
    }
    const double elapsed = std::chrono::duration<double>(now - stage_start_).count();
    const bool finished = done >= total;
    if (!tty_ && !finished && std::chrono::duration<double>(now - last_print_).count() < 2.0)
        return;
    last_print_ = now;
    char eta[48] = "";
    if (!finished && done > 0)
        std::snprintf(eta, sizeof eta, ", ETA %.1f s",
                      elapsed / static_cast<double>(done) * static_cast<double>(total - done));
    else if (finished)
        std::snprintf(eta, sizeof eta, " in %.2f s", elapsed);
    std::fprintf(stderr, "%s[%s] %zu/%zu%s%s", tty_ ? "\r\033[K" : "", stage.c_str(), done, total, eta,
                 tty_ && !finished ? "" : "\n");
    std::fflush(stderr);
}

} // namespace calib::app
