#include "pipeline/verification/verification.h"

#include "pipeline/signal/first_failure.h"
#include "pipeline/signal/peaks.h"
#include "pipeline/transfer/playback.h"
#include "pipeline/transfer/transfer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

// Lanczos (a = 4) upsampling of a lattice field by an integer factor,
// separable: the lattice holds >= 4 points per shortest wavelength (6 at the
// pulse centre), where the windowed sinc recovers the field between points to
// about 1e-3 (a cubic loses a few per cent at the peak, and the spot with it).
std::vector<float> upsample_lanczos(const std::vector<float> &f, int cols, int rows, int factor)
{
    constexpr int a = 4;
    auto lanczos = [&](double x) {
        if (x == 0)
            return 1.0;
        if (std::abs(x) >= a)
            return 0.0;
        const double px = std::numbers::pi * x;
        return a * std::sin(px) * std::sin(px / a) / (px * px);
    };
    const int nc = (cols - 1) * factor + 1, nr = (rows - 1) * factor + 1;
    // Rows first (x), then columns (y).
    std::vector<double> tmp(std::size_t(nc) * rows);
    for (int j = 0; j < rows; j++)
        for (int I = 0; I < nc; I++) {
            const int i = I / factor;
            const double t = double(I - i * factor) / factor;
            double acc = 0, wsum = 0;
            for (int m = -a + 1; m <= a; m++) {
                const double w = lanczos(t - m);
                const int ii = std::clamp(i + m, 0, cols - 1);
                acc += w * f[std::size_t(j) * cols + ii];
                wsum += w;
            }
            tmp[std::size_t(j) * nc + I] = acc / wsum;
        }
    std::vector<float> out(std::size_t(nc) * nr);
    for (int J = 0; J < nr; J++) {
        const int j = J / factor;
        const double t = double(J - j * factor) / factor;
        for (int I = 0; I < nc; I++) {
            double acc = 0, wsum = 0;
            for (int m = -a + 1; m <= a; m++) {
                const double w = lanczos(t - m);
                acc += w * tmp[std::size_t(std::clamp(j + m, 0, rows - 1)) * nc + I];
                wsum += w;
            }
            out[std::size_t(J) * nc + I] = static_cast<float>(acc / wsum);
        }
    }
    return out;
}

} // namespace

bool is_other_focus(const CalibrationInput &in, std::size_t f, std::size_t g, double lambda_half_m)
{
    const Point a = in.foci.points[f].at, b = in.foci.points[g].at;
    return g != f && dist(a, b) > lambda_half_m;
}

std::vector<float> to_unit(const std::vector<int16_t> &s)
{
    std::vector<float> v(s.size());
    for (size_t i = 0; i < s.size(); i++)
        v[i] = static_cast<float>(s[i]) / 32767.0f;
    return v;
}

double spot_diameter(const std::vector<float> &field, int nx, int ny, double h, Point focus, double level)
{
    const int i0 = std::clamp(static_cast<int>(std::lround(focus.x_m / h)), 0, nx);
    const int j0 = std::clamp(static_cast<int>(std::lround(focus.y_m / h)), 0, ny);
    const int w = nx + 1, ht = ny + 1;
    std::vector<char> seen(field.size(), 0);
    std::vector<std::pair<int, int>> stack{{i0, j0}};
    size_t count = 0;
    while (!stack.empty()) {
        auto [i, j] = stack.back();
        stack.pop_back();
        if (i < 0 || j < 0 || i >= w || j >= ht)
            continue;
        const size_t n = static_cast<size_t>(j) * w + i;
        if (seen[n] || field[n] < level)
            continue;
        seen[n] = 1;
        count++;
        stack.insert(stack.end(), {{i + 1, j}, {i - 1, j}, {i, j + 1}, {i, j - 1}});
    }
    return 2.0 * std::sqrt(static_cast<double>(count) * h * h / std::numbers::pi);
}

namespace {

// Samples of the playback output: the drive and the verification tail.
size_t output_samples(const CalibrationInput &in, const TransferMatrix &H, size_t drive_samples)
{
    return drive_samples + static_cast<size_t>(std::ceil(in.calibration.verify_tail_s * H.rate_hz));
}

size_t longest(const std::vector<std::vector<int16_t>> &signals, size_t channels)
{
    size_t n = 0;
    for (const auto &s : signals)
        n = std::max(n, s.size() / channels);
    return n;
}

void require_finite(const std::vector<float> &w, uint32_t id)
{
    for (float v : w)
        if (!std::isfinite(v))
            throw std::runtime_error("focus " + std::to_string(id) + ": non-finite displacement in the playback");
}

} // namespace

std::vector<double> focal_peaks(const CalibrationInput &in, const TransferMatrix &H,
                                const std::vector<std::vector<int16_t>> &signals, double rate_hz)
{
    const size_t K = in.foci.points.size(), C = H.channels;
    const size_t drive = static_cast<size_t>(std::ceil(double(longest(signals, C)) * H.rate_hz / rate_hz)) + 1;
    std::vector<size_t> foci(K);
    for (size_t f = 0; f < K; f++)
        foci[f] = H.exact_begin() + f;
    Playback pb(H, foci, drive, output_samples(in, H, drive));
    std::vector<double> peaks(K);
    // One focus per thread (Playback::field is const, FFTW's execute is
    // thread-safe): the figures do not depend on the thread count.
    FirstFailure failure;
#pragma omp parallel for schedule(dynamic)
    for (size_t f = 0; f < K; f++) {
        try {
            const auto w = pb.field(drive_forces(in, H, to_unit(signals[f]), unsigned(C), rate_hz), {f});
            require_finite(w[0], in.foci.points[f].id);
            peaks[f] = refined_peak(w[0]).value;
        } catch (const std::exception &e) {
            failure.keep(f, e.what());
        }
    }
    failure.rethrow();
    return peaks;
}

Verification verify_signals_with(const CalibrationInput &in, const TransferMatrix &H,
                                 const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                                 const ProgressFn &progress, bool whole_area)
{
    const size_t K = in.foci.points.size(), C = H.channels, L = whole_area ? H.lattice.size() : 0;
    if (signals.size() != K)
        throw std::invalid_argument("verification: " + std::to_string(signals.size()) + " signals for " +
                                    std::to_string(K) + " foci");
    const size_t drive = static_cast<size_t>(std::ceil(double(longest(signals, C)) * H.rate_hz / rate_hz)) + 1;
    std::vector<size_t> served; // the foci, then the lattice
    for (size_t f = 0; f < K; f++)
        served.push_back(H.exact_begin() + f);
    for (size_t n = 0; n < L; n++)
        served.push_back(n);
    Playback pb(H, served, drive, output_samples(in, H, drive));
    const double R = H.rate_hz, k = H.time_step_s, M = double(H.decimation);
    const double lambda_half = judged_lambda_half_m(in);
    const double thr = in.calibration.threshold_m;
    const ObservationLattice &lat = H.lattice;
    const double cell = lat.spacing_m * lat.spacing_m;
    const Rect &area = in.active.area;
    std::vector<char> active(L);
    for (size_t n = 0; n < L; n++)
        active[n] = area.contains(lat.at(n));

    Verification v;
    v.foci.resize(K);
    v.traces.resize(K);
    v.snapshots.resize(K);
    v.trace_rate_hz = R;
    if (L > 0) {
        v.grid_nx = lat.cols - 1;
        v.grid_ny = lat.rows - 1;
        v.grid_h_m = lat.spacing_m;
        v.max_abs.resize(K);
    }
    // One focus: its playback, the figures at the foci, and over the whole area.
    auto measure = [&](size_t f) {
        const std::vector<float> frames = to_unit(signals[f]);
        const auto w = pb.field(drive_forces(in, H, frames, unsigned(C), rate_hz));
        FocusMetrics &m = v.foci[f];
        m.id = in.foci.points[f].id;
        m.at = in.foci.points[f].at;
        m.lambda_half_m = lambda_half;
        for (size_t g = 0; g < K; g++)
            require_finite(w[g], in.foci.points[g].id);
        const Peak pk = refined_peak(w[f]);
        m.peak_m = pk.value;
        m.lead_time_s = pk.index * M * k + k; // trace index s M is the state after step s M
        size_t others = 0;
        for (size_t g = 0; g < K; g++) {
            v.traces[f].emplace_back(w[g].begin(), w[g].end());
            if (!is_other_focus(in, f, g, lambda_half))
                continue;
            others++;
            if (sample_peak(w[g].data(), w[g].size()) >= 0.8 * m.max_other_foci_m)
                m.max_other_foci_m = std::max(m.max_other_foci_m, refined_peak(w[g]).value);
        }
        m.other_foci_contrast_db = others > 0 ? ratio_db(m.peak_m, m.max_other_foci_m) : 0.0;
        m.crosses_threshold = m.peak_m >= thr;
        m.others_below_threshold = m.max_other_foci_m < thr;
        if (L == 0)
            return;

        // Whole area, all times: sample maxima, then the candidates refined.
        std::vector<float> &mx = v.max_abs[f];
        mx.assign(L, 0.0f);
        double far_sample = 0;
        for (size_t n = 0; n < L; n++) {
            if (!active[n])
                continue;
            const std::vector<float> &x = w[K + n];
            mx[n] = static_cast<float>(sample_peak(x.data(), x.size()));
            if (dist(lat.at(n), m.at) > lambda_half)
                far_sample = std::max(far_sample, double(mx[n]));
        }
        const double refine_above = 0.8 * std::min(thr, far_sample);
        double sx = 0, sy = 0;
        size_t above = 0;
        for (size_t n = 0; n < L; n++) {
            if (!active[n])
                continue;
            if (mx[n] >= refine_above)
                mx[n] = static_cast<float>(refined_peak(w[K + n]).value);
            const Point p = lat.at(n);
            if (dist(p, m.at) > lambda_half && mx[n] > m.max_whole_area_m) {
                m.max_whole_area_m = mx[n];
                m.whole_area_max_at = p;
            }
            if (mx[n] >= thr) {
                sx += p.x_m;
                sy += p.y_m;
                above++;
            }
        }
        m.whole_area = true;
        m.whole_area_contrast_db = ratio_db(m.peak_m, m.max_whole_area_m);
        m.whole_area_below_threshold = m.max_whole_area_m < thr;
        m.area_above_threshold_m2 = double(above) * cell;
        if (above > 0) {
            m.perceived_offset_m = {sx / double(above) - m.at.x_m, sy / double(above) - m.at.y_m};
            m.perceived_offset_distance_m = std::hypot(m.perceived_offset_m.x_m, m.perceived_offset_m.y_m);
        }

        // The field at the focus instant, on the lattice and (for the spot)
        // upsampled (Lanczos) to the plate grid.
        std::vector<float> &snap = v.snapshots[f];
        std::vector<float> signed_snap(L);
        snap.resize(L);
        for (size_t n = 0; n < L; n++) {
            signed_snap[n] = static_cast<float>(interpolate(w[K + n].data(), w[K + n].size(), pk.index));
            snap[n] = std::abs(signed_snap[n]);
        }
        for (size_t n = 0; n < L; n++) {
            const Point p = lat.at(n);
            if (dist(p, m.at) > lambda_half)
                m.max_elsewhere_m = std::max(m.max_elsewhere_m, double(snap[n]));
        }
        m.field_contrast_db = ratio_db(m.peak_m, m.max_elsewhere_m);
        std::vector<float> fine = upsample_lanczos(signed_snap, lat.cols, lat.rows, lat.stride);
        for (float &x : fine)
            x = std::abs(x);
        m.spot_diameter_m = spot_diameter(fine, (lat.cols - 1) * lat.stride, (lat.rows - 1) * lat.stride,
                                          lat.spacing_m / lat.stride, m.at, m.peak_m / 2);
    };
    FirstFailure failure;
    size_t done = 0;
#pragma omp parallel for schedule(dynamic)
    for (size_t f = 0; f < K; f++) {
        try {
            measure(f);
        } catch (const std::exception &e) {
            failure.keep(f, e.what());
        }
#pragma omp critical(verification_progress)
        {
            done++;
            if (progress)
                progress("verify", done, K);
        }
    }
    failure.rethrow();
    if (L > 0 && K > 0) {
        const size_t worst = summarize_verdict(v.foci).worst;
        v.worst_focus = worst;
        v.frame_rate_hz = R;
        std::vector<size_t> lattice_rows(L);
        for (size_t n = 0; n < L; n++)
            lattice_rows[n] = K + n;
        const auto w = pb.field(drive_forces(in, H, to_unit(signals[worst]), unsigned(C), rate_hz), lattice_rows);
        v.frames.assign(pb.output_samples(), std::vector<float>(L));
        for (size_t n = 0; n < L; n++)
            for (size_t s = 0; s < w[n].size(); s++)
                v.frames[s][n] = w[n][s];
    }
    return v;
}

Verification verify_drive_with(const CalibrationInput &in, const TransferMatrix &H, const std::vector<float> &frames,
                               unsigned channels, double rate_hz)
{
    if (channels != H.channels)
        throw std::invalid_argument("drive has " + std::to_string(channels) + " channels for " +
                                    std::to_string(H.channels) + " exciters");
    const size_t K = in.foci.points.size();
    const auto force = drive_forces(in, H, frames, channels, rate_hz);
    size_t drive = 1;
    for (const auto &c : force)
        drive = std::max(drive, c.size());
    std::vector<size_t> foci(K);
    for (size_t f = 0; f < K; f++)
        foci[f] = H.exact_begin() + f;
    Playback pb(H, foci, drive, output_samples(in, H, drive));
    const auto w = pb.field(force);
    Verification v;
    v.trace_rate_hz = H.rate_hz;
    v.traces.emplace_back();
    v.foci.resize(K);
    for (size_t g = 0; g < K; g++) {
        require_finite(w[g], in.foci.points[g].id);
        FocusMetrics &m = v.foci[g];
        m.id = in.foci.points[g].id;
        m.at = in.foci.points[g].at;
        m.lambda_half_m = judged_lambda_half_m(in);
        const Peak pk = refined_peak(w[g]);
        m.peak_m = pk.value;
        m.lead_time_s = pk.index * double(H.decimation) * H.time_step_s + H.time_step_s;
        m.crosses_threshold = m.peak_m >= in.calibration.threshold_m;
        v.traces[0].emplace_back(w[g].begin(), w[g].end());
    }
    return v;
}

Verification verify_signals(const CalibrationInput &in, const std::vector<Point> &exciters,
                            const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                            const ProgressFn &progress, bool whole_area)
{
    if (!transfer_holds(in))
        return verify_signals_forward(in, exciters, signals, rate_hz, progress, whole_area);
    return verify_signals_with(in, transfer_for(in, exciters, progress), signals, rate_hz, progress, whole_area);
}

Verification verify_drive(const CalibrationInput &in, const std::vector<Point> &exciters,
                          const std::vector<float> &frames, unsigned channels, double rate_hz,
                          const ProgressFn &progress)
{
    if (channels != exciters.size())
        throw std::invalid_argument("drive has " + std::to_string(channels) + " channels for " +
                                    std::to_string(exciters.size()) + " exciters");
    if (!transfer_holds(in))
        return verify_drive_forward(in, exciters, frames, channels, rate_hz, progress);
    const TransferMatrix H = transfer_for(in, exciters, progress);
    if (progress)
        progress("verify drive", 0, 1);
    Verification v = verify_drive_with(in, H, frames, channels, rate_hz);
    if (progress)
        progress("verify drive", 1, 1);
    return v;
}

} // namespace calib::pipeline
