// A real FFT of one size in double through FFTW: planned once (FFTW_ESTIMATE,
// the planner serialized), then run as often as needed on its own buffers
// from one thread at a time.
#pragma once
#include <complex>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>

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
    double *real() { return real_; }                   // size() samples
    std::complex<double> *spectrum() { return spec_; } // bins() bins
    void forward();                                    // real() -> spectrum()
    // x[0..count) zero-padded to size() into real(), then forward().
    template <typename T>
    void forward_padded(const T *x, std::size_t count)
    {
        const std::size_t m = count < n_ ? count : n_;
        for (std::size_t i = 0; i < m; i++)
            real_[i] = double(x[i]);
        for (std::size_t i = m; i < n_; i++)
            real_[i] = 0.0;
        forward();
    }
    void inverse(); // spectrum() -> real(), unnormalized (n times the signal); spectrum() is overwritten

  private:
    std::size_t n_;
    double *real_ = nullptr;
    std::complex<double> *spec_ = nullptr;
    void *forward_ = nullptr, *inverse_ = nullptr;
};

// One transform per OpenMP thread, made inside a parallel region: on failure
// the first message goes to `failure` and the result is null. A thread without
// one must still enter the region's work-sharing loops (and skip its share).
std::unique_ptr<RealFft> thread_fft(std::size_t n, std::string &failure);

// The smallest power of two >= n (1 for 0): a transform's size where a
// linear convolution of n samples must not wrap.
std::size_t next_pow2(std::size_t n);

} // namespace calib::pipeline
