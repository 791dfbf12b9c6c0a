// Exceptions out of an OpenMP parallel loop over foci: an exception cannot
// leave a parallel region, so each iteration catches its own and keeps it
// here; after the loop the failure of the first focus in scene order (the
// one a serial loop would have reported) is thrown, whatever the threads did.
#pragma once
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

class FirstFailure {
  public:
    void keep(std::size_t item, const std::string &what)
    {
#pragma omp critical(calib_first_failure)
        if (item < item_) {
            item_ = item;
            what_ = what;
        }
    }
    // Throws std::runtime_error with the kept message, if any.
    void rethrow() const
    {
        if (item_ != SIZE_MAX)
            throw std::runtime_error(what_);
    }

    bool failed() const { return item_ != SIZE_MAX; }
    std::size_t item() const { return item_; }
    const std::string &what() const { return what_; }

  private:
    std::size_t item_ = SIZE_MAX;
    std::string what_;
};

} // namespace calib::pipeline
