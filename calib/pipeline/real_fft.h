// A real FFT of one size in double through FFTW: planned once (FFTW_ESTIMATE,
// the planner serialized), then run as often as needed on its own buffers
// from one thread at a time.
#pragma once
#include <complex>
#include <cstddef>
#include <mutex>

namespace calib::pipeline {

// FFTW's planner is global and not thread-safe: every plan is made and
// destroyed under this lock (execution needs none).
std::mutex &fftw_planner_mutex();

class RealFft {
public:
    explicit RealFft(std::size_t n);
    ~RealFft();
    RealFft(const RealFft &) = delete;
    RealFft &operator=(const RealFft &) = delete;

    std::size_t size() const { return n_; }
    std::size_t bins() const { return n_ / 2 + 1; }
    double *real() { return real_; }                  // size() samples
    std::complex<double> *spectrum() { return spec_; }  // bins() bins
    void forward();  // real() -> spectrum()
    void inverse();  // spectrum() -> real(), unnormalized (n times the signal); spectrum() is overwritten

private:
    std::size_t n_;
    double *real_ = nullptr;
    std::complex<double> *spec_ = nullptr;
    void *forward_ = nullptr, *inverse_ = nullptr;
};

}  // namespace calib::pipeline
