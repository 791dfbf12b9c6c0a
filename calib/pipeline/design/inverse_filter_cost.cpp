#include "pipeline/design/inverse_filter_cost.h"

#include "pipeline/design/block_toeplitz.h"
#include "pipeline/design/shared_designs.h"
#include "pipeline/transfer/playback.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <utility>

#include <omp.h>

namespace calib::pipeline {

InverseFilterShape inverse_filter_shape(const CalibrationInput &in, double rate_hz, std::size_t samples,
                                        const ObservationLattice &lattice)
{
    InverseFilterShape s;
    s.channels = in.exciters.count;
    s.samples = samples;
    s.rate_hz = rate_hz;
    s.drive_samples = scene_drive_samples(in, rate_hz);
    s.points = lattice_in_area(in, lattice).size() + in.foci.points.size();
    if (in.robust)
        s.plates += in.robust->loss.size() + in.robust->youngs_scale.size();
    return s;
}

double inverse_filter_bytes(const InverseFilterShape &s, std::size_t running)
{
    const double C = double(s.channels), J = double(s.drive_samples), P = double(s.points);
    const double bins = double(fft_friendly_size(std::max<std::size_t>(2, s.drive_samples + s.samples)) / 2 + 1);
    const double shared = C * (C + 1) / 2 * double(lag_count(s.drive_samples)) * P * 8      // Rp
                          + double(s.plates) * P * C * bins * 8;                            // playback spectra
    const double design = (C * J) * (C * J) * 8                                             // block Levinson's U
                          + double(s.plates) * P * double(s.drive_samples + s.samples) * 4; // fields
    return shared + double(running) * design;
}

InverseFilterSeconds time_inverse_filter(const InverseFilterShape &s, const InverseFilterOptions &o)
{
    using Clock = std::chrono::steady_clock;
    if (s.channels == 0 || s.samples == 0 || s.drive_samples == 0 || !(s.rate_hz > 0))
        throw std::invalid_argument("inverse filter: an empty shape to time");
    // Timed on at most 16 exciters, C J <= 4096 (block Levinson's factor
    // 128 MB) and a random H of at most 64 MB, then scaled as the work grows:
    // C^3 J^2 for block Levinson, the rest within it. A scene that large
    // is priced, not run (its memory refuses it).
    const std::size_t C = std::min<std::size_t>(s.channels, 16);
    const std::size_t J = std::min(s.drive_samples, std::max<std::size_t>(1, 4096 / C));
    const std::size_t S = std::min(s.samples, std::max<std::size_t>(1, (std::size_t(1) << 24) / (64 * C)));
    const double scale = std::pow(double(s.channels) / double(C), 3) *
                         std::pow(double(s.drive_samples) / double(J), 2) *
                         std::max(1.0, double(s.samples) / double(S));
    InverseFilterOptions one_pass = o;
    one_pass.minimax_iterations = std::min(o.minimax_iterations, 1);
    const double passes = double(std::max(o.minimax_iterations, 0) + 1);
    // Random decaying responses (a fixed LCG: the same every run).
    auto timed = [&](std::size_t points) {
        TransferMatrix H;
        H.channels = C;
        H.samples = S;
        H.rate_hz = s.rate_hz;
        H.lattice.cols = int(points);
        H.lattice.rows = 1;
        H.points.resize(points);
        H.data.resize(C * points * S);
        // Low-passed noise: a plate's responses are coloured, and their normal
        // matrix has a dominant eigenvalue, which the Lanczos estimate of the
        // regularisation finds in few iterations (white noise would take
        // several times longer than any plate).
        uint64_t x = 88172645463325252ull;
        double y = 0;
        for (std::size_t i = 0; i < H.data.size(); i++) {
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            const double u = double(x >> 11) * 0x1.0p-53 - 0.5;
            y = (i % S == 0 ? 0.0 : 0.97 * y) + u;
            H.data[i] = float(y * std::exp(-4.0 * double(i % S) / double(S)));
        }
        InverseFilterProblem p;
        p.drive_samples = J;
        p.foci = {0};
        for (std::size_t q = 1; q < points; q++)
            p.control.push_back(q);
        // Two cycles under a Hann window, centred near the end of the drive.
        const std::size_t start = J > 8 ? J - 8 : 0;
        p.target.assign(start + 16, 0.0);
        for (std::size_t n = 0; n < 16; n++)
            p.target[start + n] = std::sin(std::numbers::pi * double(n) / 4) *
                                  (0.5 - 0.5 * std::cos(2 * std::numbers::pi * double(n) / 16));
        std::vector<std::size_t> all(points);
        for (std::size_t q = 0; q < points; q++)
            all[q] = q;
        const Plates plates(s.plates, &H);
        // The fastest of three (a shared machine only slows a run down), one
        // minimax pass after the first design: a pass costs the same each time.
        double shared_s = INFINITY, design_s = INFINITY;
        for (int r = 0; r < 3; r++) {
            const auto t0 = Clock::now();
            const SharedDesigns shared(plates, all, J);
            const auto t1 = Clock::now();
            (void)shared.minimax(p, one_pass);
            const auto t2 = Clock::now();
            shared_s = std::min(shared_s, std::chrono::duration<double>(t1 - t0).count());
            design_s = std::min(design_s, std::chrono::duration<double>(t2 - t1).count());
        }
        return std::pair{shared_s, design_s * passes / double(one_pass.minimax_iterations + 1)};
    };
    const std::size_t p1 = 8, p2 = 64;
    InverseFilterSeconds out;
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    try {
        const auto [s1, d1] = timed(p1);
        const auto [s2, d2] = timed(p2);
        omp_set_num_threads(threads);
        auto at = [&](double a, double b) {
            const double slope = std::max(0.0, (b - a) / double(p2 - p1));
            return std::max(a, b) + slope * std::max(0.0, double(s.points) - double(p2));
        };
        out.shared_s = at(s1, s2) * scale;
        out.per_focus_s = at(d1, d2) * scale;
    } catch (...) {
        omp_set_num_threads(threads);
        throw;
    }
    return out;
}

} // namespace calib::pipeline
