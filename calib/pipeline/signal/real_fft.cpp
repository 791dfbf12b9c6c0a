#include "pipeline/signal/real_fft.h"

#include <fftw3.h>

#include <new>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

std::mutex &fftw_planner_mutex()
{
    static std::mutex m;
    return m;
}

RealFft::RealFft(std::size_t n) : n_(n)
{
    if (n < 2)
        throw std::invalid_argument("real FFT: size below 2");
    real_ = fftw_alloc_real(n);
    spec_ = reinterpret_cast<std::complex<double> *>(fftw_alloc_complex(bins()));
    if (!real_ || !spec_) {
        fftw_free(real_);
        fftw_free(spec_);
        throw std::bad_alloc();
    }
    auto *spec = reinterpret_cast<fftw_complex *>(spec_);
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    forward_ = fftw_plan_dft_r2c_1d(int(n), real_, spec, FFTW_ESTIMATE);
    inverse_ = fftw_plan_dft_c2r_1d(int(n), spec, real_, FFTW_ESTIMATE);
    if (!forward_ || !inverse_) {
        if (forward_)
            fftw_destroy_plan(static_cast<fftw_plan>(forward_));
        if (inverse_)
            fftw_destroy_plan(static_cast<fftw_plan>(inverse_));
        fftw_free(real_);
        fftw_free(spec_);
        throw std::runtime_error("real FFT: FFTW could not plan size " + std::to_string(n));
    }
}

RealFft::~RealFft()
{
    {
        std::lock_guard<std::mutex> lock(fftw_planner_mutex());
        fftw_destroy_plan(static_cast<fftw_plan>(forward_));
        fftw_destroy_plan(static_cast<fftw_plan>(inverse_));
    }
    fftw_free(real_);
    fftw_free(spec_);
}

void RealFft::forward() { fftw_execute(static_cast<fftw_plan>(forward_)); }
void RealFft::inverse() { fftw_execute(static_cast<fftw_plan>(inverse_)); }

std::unique_ptr<RealFft> thread_fft(std::size_t n, std::string &failure)
{
    try {
        return std::make_unique<RealFft>(n);
    } catch (const std::exception &ex) {
#pragma omp critical(thread_fft_failure)
        if (failure.empty())
            failure = ex.what();
        return nullptr;
    }
}

std::size_t next_pow2(std::size_t n)
{
    std::size_t p = 1;
    while (p < n)
        p <<= 1;
    return p;
}

} // namespace calib::pipeline
