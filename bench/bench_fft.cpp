// Eigen's FFT module (kissfft backend) against FFTW plans, on the real
// transforms the calibration pipeline runs: one forward (real -> half
// spectrum) and one inverse per iteration, the pair a convolution by FFT
// costs per channel. Sizes: 640, the playback of Fig. 7 through H
// (fft_friendly_size of drive + H samples, pipeline/transfer/playback.cpp); 1024, the
// placement's contrast model on Fig. 7 (power of two >= kept + window
// samples, pipeline/placement/placement.cpp); 4096 and 3 * 5^4 = 1875 for longer windows
// and rates (an FFTW-friendly size that is not a power of two).
#include <benchmark/benchmark.h>
#include <fftw3.h>
#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>
#include <vector>

namespace {

template <typename T>
std::vector<T> signal(std::size_t n)
{
    std::vector<T> x(n);
    for (std::size_t i = 0; i < n; i++)
        x[i] = T(std::sin(0.37 * double(i)) * std::exp(-double(i) / double(n)));
    return x;
}

template <typename T>
void eigen_pair(benchmark::State &state)
{
    const auto n = static_cast<std::size_t>(state.range(0));
    Eigen::FFT<T> fft;
    std::vector<T> x = signal<T>(n), y(n);
    std::vector<std::complex<T>> X;
    for (auto _ : state) {
        fft.fwd(X, x);
        fft.inv(y, X);
        benchmark::DoNotOptimize(y.data());
    }
}

// fftwf_* (float) or fftw_* (double) through one set of names.
template <typename T>
struct Fftw;
template <>
struct Fftw<float> {
    using plan = fftwf_plan;
    using complex = fftwf_complex;
    static float *real(std::size_t n) { return fftwf_alloc_real(n); }
    static complex *cplx(std::size_t n) { return fftwf_alloc_complex(n); }
    static plan r2c(int n, float *x, complex *X, unsigned f) { return fftwf_plan_dft_r2c_1d(n, x, X, f); }
    static plan c2r(int n, complex *X, float *x, unsigned f) { return fftwf_plan_dft_c2r_1d(n, X, x, f); }
    static void exec(plan p) { fftwf_execute(p); }
    static void destroy(plan p) { fftwf_destroy_plan(p); }
    static void free(void *p) { fftwf_free(p); }
};
template <>
struct Fftw<double> {
    using plan = fftw_plan;
    using complex = fftw_complex;
    static double *real(std::size_t n) { return fftw_alloc_real(n); }
    static complex *cplx(std::size_t n) { return fftw_alloc_complex(n); }
    static plan r2c(int n, double *x, complex *X, unsigned f) { return fftw_plan_dft_r2c_1d(n, x, X, f); }
    static plan c2r(int n, complex *X, double *x, unsigned f) { return fftw_plan_dft_c2r_1d(n, X, x, f); }
    static void exec(plan p) { fftw_execute(p); }
    static void destroy(plan p) { fftw_destroy_plan(p); }
    static void free(void *p) { fftw_free(p); }
};

// Plans made once (FFTW_ESTIMATE as the pipeline, or FFTW_MEASURE), executed
// per iteration; the input is restored each time (c2r overwrites its input,
// r2c does not, but the pipeline refills its buffer per channel too).
template <typename T, unsigned Flags>
void fftw_pair(benchmark::State &state)
{
    using F = Fftw<T>;
    const auto n = static_cast<std::size_t>(state.range(0));
    const std::vector<T> src = signal<T>(n);
    T *x = F::real(n);
    typename F::complex *X = F::cplx(n / 2 + 1);
    typename F::plan fwd = F::r2c(int(n), x, X, Flags);
    typename F::plan inv = F::c2r(int(n), X, x, Flags);
    for (auto _ : state) {
        std::copy(src.begin(), src.end(), x);
        F::exec(fwd);
        F::exec(inv);
        benchmark::DoNotOptimize(x);
    }
    F::destroy(fwd);
    F::destroy(inv);
    F::free(x);
    F::free(X);
}

void sizes(benchmark::internal::Benchmark *b)
{
    for (long n : {640L, 1024L, 1875L, 4096L})
        b->Arg(n);
}

} // namespace

BENCHMARK(eigen_pair<float>)->Apply(sizes);
BENCHMARK(fftw_pair<float, FFTW_ESTIMATE>)->Apply(sizes);
BENCHMARK(fftw_pair<float, FFTW_MEASURE>)->Apply(sizes);
BENCHMARK(eigen_pair<double>)->Apply(sizes);
BENCHMARK(fftw_pair<double, FFTW_ESTIMATE>)->Apply(sizes);
BENCHMARK(fftw_pair<double, FFTW_MEASURE>)->Apply(sizes);

BENCHMARK_MAIN();
