// Progress on stderr for long stages: "[simulate] 3/9, ETA 2.1 s". On a
// terminal one line is rewritten; otherwise a line at most every 2 s and at
// the end of each stage, so logs stay short. Silent with --quiet.
#pragma once
#include "pipeline/calibrate.h"

#include <chrono>
#include <mutex>
#include <string>

namespace calib::app {

class Progress {
  public:
    explicit Progress(bool quiet);
    pipeline::ProgressFn callback();
    void note(const std::string &line); // a plain line (unless quiet)

  private:
    void update(const std::string &stage, size_t done, size_t total);

    bool quiet_, tty_;
    std::mutex mutex_;
    std::string stage_;
    std::chrono::steady_clock::time_point stage_start_, last_print_;
};

} // namespace calib::app
