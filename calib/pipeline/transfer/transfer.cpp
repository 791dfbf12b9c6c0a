#include "pipeline/transfer/transfer.h"

#include "engine/simulation.h"
#include "physics/dispersion.h"
#include "pipeline/data/lead_time.h"
#include "pipeline/signal/first_failure.h"
#include "pipeline/signal/pulse.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

// Kaiser's design for an 80 dB stop band (Oppenheim & Schafer, 7.6):
// beta = 0.1102 (A - 8.7), length (A - 8) / (2.285 delta_omega).
constexpr double stop_band_db = 80.0;

} // namespace

std::vector<double> band_limited_impulse(double k, double pass_hz, double stop_hz, std::size_t &centre)
{
    if (!(stop_hz > pass_hz && pass_hz > 0 && stop_hz * k < 0.5))
        throw std::invalid_argument("band-limited force: need 0 < pass < stop < half the simulation rate");
    const double delta_omega = 2 * std::numbers::pi * (stop_hz - pass_hz) * k;
    const auto half = static_cast<std::size_t>(std::ceil((stop_band_db - 8) / (2.285 * delta_omega) / 2));
    const double beta = 0.1102 * (stop_band_db - 8.7);
    const double fc = 0.5 * (pass_hz + stop_hz) * k; // cycles per step
    std::vector<double> b(2 * half + 1);
    const double i0b = std::cyl_bessel_i(0.0, beta);
    double sum = 0;
    for (std::size_t n = 0; n < b.size(); n++) {
        const double m = double(n) - double(half);
        const double r = m / double(half);
        const double window = std::cyl_bessel_i(0.0, beta * std::sqrt(std::max(0.0, 1 - r * r))) / i0b;
        const double sinc = m == 0 ? 2 * fc : std::sin(2 * std::numbers::pi * fc * m) / (std::numbers::pi * m);
        b[n] = window * sinc;
        sum += b[n];
    }
    for (double &v : b)
        v /= sum * k; // unit impulse: sum b k = 1 N s
    centre = half;
    return b;
}

ObservationLattice observation_lattice(const CalibrationInput &in, int stride)
{
    const engine::Grid &g = in.plate->grid();
    ObservationLattice l;
    l.stride = std::max(1, stride);
    l.cols = g.nx / l.stride + 1;
    l.rows = g.ny / l.stride + 1;
    l.spacing_m = l.stride * g.h;
    return l;
}

TransferOptions transfer_options(const CalibrationInput &in, double k)
{
    TransferOptions o;
    const double f_max = pulse_max_frequency_hz(in.pulse);
    const double wanted_rate = search_rate(in.pulse);
    o.decimation = std::max<std::size_t>(1, static_cast<std::size_t>(std::floor(1.0 / (k * wanted_rate))));
    const double rate = 1.0 / (double(o.decimation) * k);
    // The kept window (the time-reversal recording) and the verification tail
    // after a drive as long as it: every playback output the verification reads.
    const double kept_s = kept_window_s(in);
    o.samples = static_cast<std::size_t>(std::ceil((kept_s + in.calibration.verify_tail_s) * rate)) + 1;
    const double lambda_min = physics::kirchhoff_wavelength_m(in.plate->kappa(), f_max);
    o.lattice_stride = std::max(1, static_cast<int>(std::floor(lambda_min / 4 / in.plate->grid().h)));
    // Flat past the pulse's band with margin; stopped from half the stored rate.
    o.stop_hz = 0.5 * rate;
    o.pass_hz = std::min(1.3 * f_max, 0.75 * o.stop_hz);
    return o;
}

std::vector<double> impulse_force(double k, double pass_hz, double stop_hz, std::size_t &centre)
{
    centre = 0;
    return stop_hz > 0 ? band_limited_impulse(k, pass_hz, stop_hz, centre) : std::vector<double>{1.0 / k};
}

std::vector<engine::LaneRecord> impulse_lanes(std::shared_ptr<const engine::PlateOperator> plate,
                                              const engine::SimulationOptions &options,
                                              const std::vector<Point> &sources, const std::vector<Point> &receivers,
                                              int lattice_stride, double pass_hz, double stop_hz, std::size_t interval,
                                              std::size_t samples,
                                              const std::function<void(std::size_t, std::size_t)> &progress)
{
    engine::LanesRequest rq;
    for (const Point &p : sources)
        rq.sources.push_back({p.x_m, p.y_m});
    for (const Point &p : receivers)
        rq.receivers.push_back({p.x_m, p.y_m});
    rq.force_n = impulse_force(engine::kirchhoff_time_step(*plate, options), pass_hz, stop_hz, rq.first_step);
    rq.lattice_stride = lattice_stride;
    rq.interval = interval;
    rq.samples = samples;
    engine::SimulationOptions team = options;
    team.engine.threads = 0; // the batches share the OpenMP team
    return engine::simulate_lanes(std::move(plate), team, rq, progress);
}

TransferMatrix simulate_transfer(const CalibrationInput &in, const std::vector<Point> &exciters,
                                 const std::vector<Point> &exact_points, const TransferOptions &o,
                                 const TransferProgress &progress)
{
    TransferMatrix H;
    H.channels = exciters.size();
    H.exciters = exciters;
    H.samples = o.samples;
    H.decimation = std::max<std::size_t>(1, o.decimation);
    if (o.lattice_stride > 0) {
        H.lattice = observation_lattice(in, o.lattice_stride);
        for (std::size_t n = 0; n < H.lattice.size(); n++)
            H.points.push_back(H.lattice.at(n));
    }
    H.points.insert(H.points.end(), exact_points.begin(), exact_points.end());
    const std::size_t P = H.points.size(), S = H.samples, L = H.lattice.size();
    H.data.assign(H.channels * P * S, 0.0f);
    const engine::SimulationOptions options = single_core_options(in);
    // Per exciter, the lattice frames and the exact points' traces, sample s
    // the state after step centre + s M: side by side in the engine's lanes
    // where the plate allows (engine/lanes.h), else one Simulation each.
    std::vector<engine::LaneRecord> rec(H.channels);
    if (engine::lanes_apply(*in.plate, options)) {
        const double k = engine::kirchhoff_time_step(*in.plate, options);
        H.time_step_s = k;
        H.rate_hz = 1.0 / (double(H.decimation) * k);
        try {
            rec = impulse_lanes(in.plate, options, exciters, exact_points, L > 0 ? H.lattice.stride : 0, o.pass_hz,
                                o.stop_hz, H.decimation, S, progress);
        } catch (const engine::SourceFailure &ex) {
            throw std::runtime_error("transfer matrix, exciter " + std::to_string(ex.source() + 1) + ": " + ex.what());
        }
    } else {
        std::size_t done = 0;
        FirstFailure failure;
#pragma omp parallel for schedule(dynamic)
        for (std::size_t c = 0; c < H.channels; c++) {
            try {
                engine::Simulation sim(in.plate, options);
                const double k = sim.time_step_s();
#pragma omp critical
                {
                    H.time_step_s = k;
                    H.rate_hz = 1.0 / (double(H.decimation) * k);
                }
                const std::size_t src = sim.add_source(exciters[c].x_m, exciters[c].y_m);
                std::size_t centre = 0;
                sim.set_source_signal(src, impulse_force(k, o.pass_hz, o.stop_hz, centre));
                for (const Point &p : exact_points)
                    sim.add_receiver(p.x_m, p.y_m);
                if (L > 0)
                    sim.record_lattice(H.lattice.stride, centre, H.decimation);
                sim.run(centre + (S - 1) * H.decimation + 1);
                rec[c].lattice = sim.lattice_frames();
                for (const std::vector<double> &tr : sim.traces()) {
                    rec[c].traces.emplace_back(S);
                    for (std::size_t s = 0; s < S; s++)
                        rec[c].traces.back()[s] = tr[centre + s * H.decimation];
                }
            } catch (const std::exception &ex) {
                failure.keep(c, "transfer matrix, exciter " + std::to_string(c + 1) + ": " + ex.what());
            }
#pragma omp critical
            {
                done++;
                if (progress)
                    progress(done, H.channels);
            }
        }
        failure.rethrow();
    }
    for (std::size_t c = 0; c < H.channels; c++) {
        float *out = H.data.data() + c * P * S;
        for (std::size_t s = 0; s < S && L > 0; s++)
            for (std::size_t n = 0; n < L; n++)
                out[n * S + s] = rec[c].lattice[s * L + n];
        for (std::size_t r = 0; r < exact_points.size(); r++)
            for (std::size_t s = 0; s < S; s++)
                out[(L + r) * S + s] = static_cast<float>(rec[c].traces[r][s]);
    }
    return H;
}

void apply_force_gains(const CalibrationInput &in, TransferMatrix &H)
{
    if (in.exciters.force_gains.empty())
        return;
    if (in.exciters.force_gains.size() != H.channels)
        throw std::invalid_argument("exciters.force_gains: " + std::to_string(in.exciters.force_gains.size()) +
                                    " gains for " + std::to_string(H.channels) + " exciters");
    const std::size_t block = H.point_count() * H.samples;
    for (std::size_t c = 0; c < H.channels; c++) {
        const auto g = static_cast<float>(in.exciters.force_gain(c));
        for (std::size_t i = 0; i < block; i++)
            H.data[c * block + i] *= g;
    }
}

TransferMatrix transfer_for(const CalibrationInput &in, const std::vector<Point> &exciters, const ProgressFn &progress)
{
    engine::Simulation probe(in.plate, single_core_options(in));
    const TransferOptions o = transfer_options(in, probe.time_step_s());
    std::vector<Point> foci;
    for (const FocusPoint &f : in.foci.points)
        foci.push_back(f.at);
    TransferMatrix H = simulate_transfer(in, exciters, foci, o, [&](size_t done, size_t total) {
        if (progress)
            progress("transfer", done, total);
    });
    apply_force_gains(in, H);
    return H;
}

} // namespace calib::pipeline
