#include "pipeline/verification/radiation.h"

#include "pipeline/data/input.h"
#include "pipeline/signal/real_fft.h"
#include "pipeline/transfer/playback.h"
#include "pipeline/verification/verification.h"

#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <memory>

namespace calib::pipeline {

double a_weighting(double f)
{
    if (!(f > 0))
        return 0.0;
    const double f2 = f * f;
    const double ra =
        12194.0 * 12194.0 * f2 * f2 /
        ((f2 + 20.6 * 20.6) * std::sqrt((f2 + 107.7 * 107.7) * (f2 + 737.9 * 737.9)) * (f2 + 12194.0 * 12194.0));
    return ra * std::pow(10.0, 2.0 / 20); // +2.00 dB: unity at 1 kHz
}

std::vector<double> rayleigh_pressure(const ObservationLattice &lattice, const std::vector<std::vector<float>> &w,
                                      double R, Point listener, double z, std::size_t samples)
{
    std::size_t N = 1;
    while (N < samples + 64) // room for the largest propagation delay
        N *= 2;
    const double dA = lattice.spacing_m * lattice.spacing_m;
    std::vector<std::complex<double>> P(N, 0.0), W;
    std::vector<double> x(N);
    Eigen::FFT<double> fft;
    for (std::size_t n = 0; n < w.size() && n < lattice.size(); n++) {
        const Point p = lattice.at(n);
        const double dist = std::sqrt((p.x_m - listener.x_m) * (p.x_m - listener.x_m) +
                                      (p.y_m - listener.y_m) * (p.y_m - listener.y_m) + z * z);
        std::fill(x.begin(), x.end(), 0.0);
        const std::size_t m = std::min(w[n].size(), samples);
        std::copy(w[n].begin(), w[n].begin() + long(m), x.begin());
        // The plate still rings where the record ends: a raised-cosine fade
        // over its last 10 ms (at most an eighth of it), so the cut is not
        // heard as a click that is not there.
        const std::size_t fade = std::min(m / 8, static_cast<std::size_t>(0.01 * R));
        for (std::size_t i = 0; i < fade; i++)
            x[m - 1 - i] *= 0.5 * (1 - std::cos(std::numbers::pi * (double(i) + 0.5) / double(fade)));
        fft.fwd(W, x);
        const double tau = dist / sound_speed_m_s;
        for (std::size_t k = 0; k < N; k++) {
            const double f = (k <= N / 2 ? double(k) : double(k) - double(N)) * R / double(N);
            const double om = 2 * std::numbers::pi * f;
            // acceleration -omega^2 W, delayed by R_n / c0, over R_n
            P[k] += -om * om * W[k] * std::polar(1.0, -om * tau) * (dA / dist);
        }
    }
    for (auto &v : P)
        v *= air_density_kg_m3 / (2 * std::numbers::pi);
    std::vector<double> p;
    fft.inv(p, P);
    p.resize(samples);
    return p;
}

double a_weighted_exposure(const std::vector<double> &p, double R)
{
    std::size_t N = 1;
    while (N < p.size())
        N *= 2;
    std::vector<double> x(N, 0.0);
    std::copy(p.begin(), p.end(), x.begin());
    std::vector<std::complex<double>> P;
    Eigen::FFT<double> fft;
    fft.fwd(P, x);
    double e = 0;
    for (std::size_t k = 0; k < N; k++) {
        const double f = std::abs((k <= N / 2 ? double(k) : double(k) - double(N)) * R / double(N));
        e += std::norm(P[k] * a_weighting(f));
    }
    return e / (double(N) * R); // Parseval: sum p^2 / R = sum |P|^2 / (N R)
}

std::vector<RadiatedSound> radiated_sounds(const CalibrationInput &in, const TransferMatrix &H,
                                           const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                                           double distance_m)
{
    std::vector<RadiatedSound> out(signals.size());
    const std::size_t C = H.channels, L = H.lattice.size();
    if (L == 0 || signals.empty())
        return out;
    std::vector<std::vector<std::vector<double>>> force(signals.size());
    std::size_t drive = 1;
    for (std::size_t f = 0; f < signals.size(); f++) {
        if (signals[f].empty())
            continue;
        force[f] = drive_forces(in, H, to_unit(signals[f]), unsigned(C), rate_hz);
        for (const auto &c : force[f])
            drive = std::max(drive, c.size());
    }
    const double R = H.rate_hz;
    const std::size_t samples = drive + static_cast<std::size_t>(std::ceil(in.calibration.verify_tail_s * R));
    // The pressure is linear in the drive: P(omega) = sum_c F_c(omega) Q_c(omega),
    // Q_c the Rayleigh integral of exciter c's responses over the lattice
    // (-omega^2 H_cn e^{-i omega R_n / c0} dA / R_n, times rho0 / 2 pi), formed
    // once for every focus. Linear, not circular: room for the drive, H and
    // the largest propagation delay.
    const std::size_t N = fft_friendly_size(drive + H.samples + 64);
    const std::size_t bins = N / 2 + 1;
    const auto &pp = in.plate->params();
    const Point listener{pp.size_x_m / 2, pp.size_y_m / 2};
    const double dA = H.lattice.spacing_m * H.lattice.spacing_m;
    std::vector<std::complex<double>> Q(C * bins, 0.0);
    std::vector<double> dist(L);
    for (std::size_t n = 0; n < L; n++) {
        const Point p = H.lattice.at(n);
        dist[n] = std::sqrt((p.x_m - listener.x_m) * (p.x_m - listener.x_m) +
                            (p.y_m - listener.y_m) * (p.y_m - listener.y_m) + distance_m * distance_m);
    }
    std::string failure;
#pragma omp parallel
    {
        const std::unique_ptr<RealFft> fft = thread_fft(N, failure);
#pragma omp for schedule(dynamic)
        for (std::size_t c = 0; c < C; c++) { // each exciter's Q_c on one thread
            if (!fft)
                continue;
            std::complex<double> *q = &Q[c * bins];
            for (std::size_t n = 0; n < L; n++) {
                const float *h = H.response(c, n);
                fft->forward_padded(h, H.samples);
                const double tau = dist[n] / sound_speed_m_s;
                for (std::size_t k = 0; k < bins; k++) {
                    const double om = 2 * std::numbers::pi * double(k) * R / double(N);
                    q[k] += -om * om * fft->spectrum()[k] * std::polar(dA / dist[n], -om * tau);
                }
            }
        }
    }
    // w = (1 / R) sum_j h[m - j] F[j] (transfer/playback.h), FFTW's inverse is N times.
    const double scale = air_density_kg_m3 / (2 * std::numbers::pi) / (R * double(N));
    const double p0 = 20e-6;
#pragma omp parallel
    {
        const std::unique_ptr<RealFft> fft = thread_fft(N, failure);
        std::vector<std::complex<double>> acc(bins);
#pragma omp for schedule(dynamic)
        for (std::size_t f = 0; f < signals.size(); f++) {
            if (!fft || force[f].empty())
                continue;
            std::fill(acc.begin(), acc.end(), std::complex<double>{});
            for (std::size_t c = 0; c < C; c++) {
                fft->forward_padded(force[f][c].data(), force[f][c].size());
                for (std::size_t k = 0; k < bins; k++)
                    acc[k] += fft->spectrum()[k] * Q[c * bins + k];
            }
            std::copy(acc.begin(), acc.end(), fft->spectrum());
            fft->inverse();
            std::vector<double> p(fft->real(), fft->real() + std::min(samples, N));
            for (double &v : p)
                v *= scale;
            // The plate still rings where the record ends: a raised-cosine fade
            // over its last 10 ms (at most an eighth of it), so the cut is not
            // heard as a click that is not there.
            const std::size_t fade = std::min(p.size() / 8, static_cast<std::size_t>(0.01 * R));
            for (std::size_t i = 0; i < fade; i++)
                p[p.size() - 1 - i] *= 0.5 * (1 - std::cos(std::numbers::pi * (double(i) + 0.5) / double(fade)));
            RadiatedSound &o = out[f];
            for (double v : p)
                o.peak_pa = std::max(o.peak_pa, std::abs(v));
            const double energy = a_weighted_exposure(p, R);
            o.exposure_level_dba = 10 * std::log10(std::max(energy, 1e-300) / (p0 * p0));
            const double drive_s = double(signals[f].size() / C) / rate_hz;
            o.laeq_dba = 10 * std::log10(std::max(energy / drive_s, 1e-300) / (p0 * p0));
        }
    }
    if (!failure.empty())
        throw std::runtime_error("radiated sound: " + failure);
    return out;
}

} // namespace calib::pipeline
