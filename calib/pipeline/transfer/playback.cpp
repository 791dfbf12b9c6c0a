#include "pipeline/transfer/playback.h"
#include "engine/effects/exciter.h"
#include "pipeline/signal/real_fft.h"
#include "pipeline/signal/resample.h"

#include <fftw3.h>

#include <algorithm>
#include <mutex>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

// Aligned FFTW buffers, freed on scope exit.
struct RealBuffer {
    float *p;
    explicit RealBuffer(std::size_t n) : p(fftwf_alloc_real(n)) {}
    ~RealBuffer() { fftwf_free(p); }
};
struct ComplexBuffer {
    fftwf_complex *p;
    explicit ComplexBuffer(std::size_t n) : p(fftwf_alloc_complex(n)) {}
    ~ComplexBuffer() { fftwf_free(p); }
};

// a = s * f (Accumulate: a += s * f) over `bins` complex bins, interleaved
// floats. The complex products written out: std::complex's operator* checks
// its result for NaN (C99 Annex G) and so stays scalar.
template <bool Accumulate>
inline void multiply_spectra(const std::complex<float> *s_bins, const std::complex<float> *f_bins, float *a,
                             std::size_t bins)
{
    const float *s = reinterpret_cast<const float *>(s_bins), *f = reinterpret_cast<const float *>(f_bins);
#pragma omp simd
    for (std::size_t b = 0; b < bins; b++) {
        const float sr = s[2 * b], si = s[2 * b + 1], fr = f[2 * b], fi = f[2 * b + 1];
        if constexpr (Accumulate) {
            a[2 * b] += sr * fr - si * fi;
            a[2 * b + 1] += sr * fi + si * fr;
        } else {
            a[2 * b] = sr * fr - si * fi;
            a[2 * b + 1] = sr * fi + si * fr;
        }
    }
}

// The inverse transform of Y (overwritten) into y, its first `out` samples
// scaled into w.
void to_time(fftwf_plan inverse, fftwf_complex *Y, float *y, std::size_t out, float scale, std::vector<float> &w)
{
    fftwf_execute_dft_c2r(inverse, Y, y);
    w.resize(out);
    for (std::size_t n = 0; n < out; n++)
        w[n] = y[n] * scale;
}

} // namespace

std::size_t fft_friendly_size(std::size_t n)
{
    for (std::size_t m = std::max<std::size_t>(n, 1);; m++) {
        std::size_t r = m;
        for (std::size_t f : {2, 3, 5, 7})
            while (r % f == 0)
                r /= f;
        if (r == 1)
            return m;
    }
}

struct Playback::Plans {
    fftwf_plan forward = nullptr, inverse = nullptr;
    ~Plans()
    {
        std::lock_guard<std::mutex> lock(fftw_planner_mutex());
        if (forward)
            fftwf_destroy_plan(forward);
        if (inverse)
            fftwf_destroy_plan(inverse);
    }
};

Playback::Playback(const TransferMatrix &H, std::vector<std::size_t> points, std::size_t drive_samples,
                   std::size_t output_samples)
    : H_(H), points_(std::move(points)), out_(output_samples), drive_(drive_samples)
{
    for (std::size_t p : points_)
        if (p >= H.point_count())
            throw std::invalid_argument("playback: point " + std::to_string(p) + " is not in the transfer matrix");
    // Linear (not circular) convolution up to output_samples: wrap-around
    // lands only past drive + H length, so nfft >= that sum keeps it out.
    nfft_ = fft_friendly_size(std::max<std::size_t>(2, drive_samples + H.samples));
    bins_ = nfft_ / 2 + 1;
    out_ = std::min(out_, nfft_);
    scale_ = 1.0 / (H.rate_hz * double(nfft_)); // dt of the sum, and FFTW's unnormalized inverse
    plans_ = std::make_unique<Plans>();
    RealBuffer x(nfft_);
    ComplexBuffer X(bins_);
    {
        std::lock_guard<std::mutex> lock(fftw_planner_mutex());
        plans_->forward = fftwf_plan_dft_r2c_1d(int(nfft_), x.p, X.p, FFTW_ESTIMATE);
        plans_->inverse = fftwf_plan_dft_c2r_1d(int(nfft_), X.p, x.p, FFTW_ESTIMATE);
    }
    if (!plans_->forward || !plans_->inverse)
        throw std::runtime_error("playback: FFTW could not plan a transform of " + std::to_string(nfft_));
    const std::size_t C = H.channels;
    spectra_.resize(points_.size() * C * bins_);
#pragma omp parallel
    {
        RealBuffer xt(nfft_);
        ComplexBuffer Xt(bins_);
#pragma omp for schedule(static)
        for (std::size_t i = 0; i < points_.size(); i++)
            for (std::size_t c = 0; c < C; c++) {
                const float *h = H.response(c, points_[i]);
                std::copy(h, h + H.samples, xt.p);
                std::fill(xt.p + H.samples, xt.p + nfft_, 0.0f);
                fftwf_execute_dft_r2c(plans_->forward, xt.p, Xt.p);
                auto *dst = spectra_.data() + (i * C + c) * bins_;
                for (std::size_t b = 0; b < bins_; b++)
                    dst[b] = {Xt.p[b][0], Xt.p[b][1]};
            }
    }
}

Playback::~Playback() = default;

double Playback::bytes() const { return double(spectra_.size()) * sizeof(std::complex<float>); }

std::vector<std::vector<float>> Playback::field(const std::vector<std::vector<double>> &force) const
{
    std::vector<std::size_t> all(points_.size());
    for (std::size_t i = 0; i < all.size(); i++)
        all[i] = i;
    return field(force, all);
}

std::vector<std::complex<float>> Playback::drive_spectra(const std::vector<std::vector<double>> &force) const
{
    const std::size_t C = H_.channels;
    if (force.size() != C)
        throw std::invalid_argument("playback: " + std::to_string(force.size()) + " drive channels for " +
                                    std::to_string(C) + " exciters");
    std::vector<std::complex<float>> F(C * bins_);
    {
        RealBuffer x(nfft_);
        ComplexBuffer X(bins_);
        for (std::size_t c = 0; c < C; c++) {
            if (force[c].size() > drive_)
                throw std::invalid_argument("playback: a drive of " + std::to_string(force[c].size()) +
                                            " samples is longer than the " + std::to_string(drive_) + " planned");
            std::fill(x.p, x.p + nfft_, 0.0f);
            for (std::size_t j = 0; j < force[c].size(); j++)
                x.p[j] = static_cast<float>(force[c][j]);
            fftwf_execute_dft_r2c(plans_->forward, x.p, X.p);
            for (std::size_t b = 0; b < bins_; b++)
                F[c * bins_ + b] = {X.p[b][0], X.p[b][1]};
        }
    }
    return F;
}

std::vector<std::vector<float>> Playback::field(const std::vector<std::vector<double>> &force,
                                                const std::vector<std::size_t> &which) const
{
    const std::size_t C = H_.channels;
    const std::vector<std::complex<float>> F = drive_spectra(force);
    std::vector<std::vector<float>> w(which.size());
    const auto scale = static_cast<float>(scale_);
#pragma omp parallel
    {
        RealBuffer y(nfft_);
        ComplexBuffer Y(bins_);
        std::vector<std::complex<float>> acc(bins_);
#pragma omp for schedule(static)
        for (std::size_t i = 0; i < which.size(); i++) {
            std::fill(acc.begin(), acc.end(), std::complex<float>{});
            const auto *S = spectra_.data() + which[i] * C * bins_;
            for (std::size_t c = 0; c < C; c++)
                multiply_spectra<true>(S + c * bins_, F.data() + c * bins_, reinterpret_cast<float *>(acc.data()),
                                       bins_);
            for (std::size_t b = 0; b < bins_; b++) {
                Y.p[b][0] = acc[b].real();
                Y.p[b][1] = acc[b].imag();
            }
            to_time(plans_->inverse, Y.p, y.p, out_, scale, w[i]);
        }
    }
    return w;
}

std::vector<std::vector<std::vector<float>>> Playback::channel_fields(const std::vector<std::vector<double>> &force,
                                                                      const std::vector<std::size_t> &which) const
{
    const std::size_t C = H_.channels;
    const std::vector<std::complex<float>> F = drive_spectra(force);
    std::vector<std::vector<std::vector<float>>> w(C, std::vector<std::vector<float>>(which.size()));
    const auto scale = static_cast<float>(scale_);
#pragma omp parallel
    {
        RealBuffer y(nfft_);
        ComplexBuffer Y(bins_);
#pragma omp for schedule(static)
        for (std::size_t i = 0; i < which.size(); i++)
            for (std::size_t c = 0; c < C; c++) {
                multiply_spectra<false>(spectra_.data() + (which[i] * C + c) * bins_, F.data() + c * bins_,
                                        reinterpret_cast<float *>(Y.p), bins_);
                to_time(plans_->inverse, Y.p, y.p, out_, scale, w[c][i]);
            }
    }
    return w;
}

std::vector<std::vector<double>> drive_forces(const CalibrationInput &in, const TransferMatrix &H,
                                              const std::vector<float> &frames, unsigned channels, double rate_hz)
{
    const size_t n = frames.size() / channels;
    std::vector<std::vector<double>> force(channels);
    std::vector<double> ch(n);
    for (unsigned c = 0; c < channels; c++) {
        for (size_t i = 0; i < n; i++)
            ch[i] = frames[i * channels + c];
        force[c] = resample(ch, rate_hz, H.rate_hz);
        for (double &v : force[c])
            v *= in.exciters.force_full_scale_n;
        if (in.effects.exciter) // the drive is Bl i; the plate gets the exciter's blocked force
            force[c] = engine::effects::blocked_force(force[c], H.rate_hz, *in.effects.exciter);
    }
    return force;
}

} // namespace calib::pipeline
