#include "pipeline/robustness/robust_design.h"

#include "pipeline/design/inverse_filter.h"
#include "pipeline/design/time_reversal.h"
#include "pipeline/robustness/tolerance.h"
#include "pipeline/signal/peaks.h"
#include "pipeline/verification/verification.h"

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace calib::pipeline {

std::vector<Perturbation> ensemble_members(const CalibrationInput &in, const RobustSpec &r)
{
    if (!transfer_holds(in))
        throw std::invalid_argument("calibration.robust: the ensemble is designed through the transfer matrix, which "
                                    "does not hold with [effects.finger]");
    const double eta0 = loss_factor(*in.plate, in.pulse.centre_hz);
    if (!r.loss.empty() && !(eta0 > 0))
        throw std::invalid_argument("calibration.robust: loss: the plate has no loss ([plate.loss]) to vary");
    std::vector<Perturbation> out;
    for (double eta : r.loss) {
        if (std::abs(eta / eta0 - 1) < 1e-9)
            continue; // the nominal plate
        out.push_back(loss_case(in, eta, "ensemble"));
    }
    for (double s : r.youngs_scale) {
        if (s == 1)
            continue;
        Perturbation p;
        char b[32];
        std::snprintf(b, sizeof b, "E x%g", s);
        p.name = b;
        p.factor = "ensemble";
        p.youngs_scale = s;
        out.push_back(p);
    }
    // Every member must take the scheme (only a forced time step may not).
    for (const Perturbation &p : in.simulation.time_step_s > 0 ? out : std::vector<Perturbation>{}) {
        try {
            perturbed_input(in, p);
        } catch (const std::invalid_argument &e) {
            throw std::invalid_argument("calibration.robust: " + p.name + ": " + e.what());
        }
    }
    return out;
}

namespace {

// A member plate: its input and its H (the foci, and the lattice when asked).
struct Member {
    CalibrationInput in;
    TransferMatrix H;
};

std::vector<Member> simulate_members(const CalibrationInput &in, const TransferMatrix &H,
                                     const std::vector<Perturbation> &members, bool lattice, const ProgressFn &progress)
{
    std::vector<Member> out;
    for (const Perturbation &m : members) {
        CalibrationInput pin = perturbed_input(in, m);
        std::optional<TransferMatrix> scaled = rescaled_transfer(in, pin, H, m); // E scalings: exact, no simulation
        TransferMatrix Hm = scaled ? std::move(*scaled) : perturbed_transfer(in, pin, H.exciters, lattice, progress);
        out.push_back({std::move(pin), std::move(Hm)});
    }
    return out;
}

// Sample s at `rate_hz` of Hm's response h: the stored sample at Hm's own
// rate, band-limited interpolation at another (an E-rescaled member, or a
// member whose loss asked for a shorter step), zero beyond its samples.
double sample_at(const TransferMatrix &Hm, const float *h, std::size_t s, double rate_hz)
{
    if (Hm.rate_hz == rate_hz)
        return s < Hm.samples ? double(h[s]) : 0.0;
    return interpolate(h, Hm.samples, double(s) * Hm.rate_hz / rate_hz);
}

// A stacked design needs every plate's H on the nominal points.
void check_same_points(const TransferMatrix &Hm, const TransferMatrix &H)
{
    if (Hm.point_count() != H.point_count() || Hm.exact_begin() != H.exact_begin() || Hm.channels != H.channels)
        throw std::runtime_error("calibration.robust: a member plate's transfer matrix has other points than the "
                                 "nominal one");
    for (std::size_t p = 0; p < H.point_count(); p++)
        if (dist(Hm.points[p], H.points[p]) > 1e-9)
            throw std::runtime_error("calibration.robust: a member plate's observation lattice is not the nominal one");
}

// Hm with H's rate and sample count (every point), for a stacked design.
TransferMatrix at_rate_of(const TransferMatrix &Hm, const TransferMatrix &H)
{
    TransferMatrix R = Hm;
    R.samples = H.samples;
    R.rate_hz = H.rate_hz;
    R.decimation = H.decimation;
    R.time_step_s = H.time_step_s;
    R.data.assign(H.channels * H.point_count() * H.samples, 0.0f);
    const std::size_t P = H.point_count();
#pragma omp parallel for schedule(static)
    for (std::size_t cp = 0; cp < H.channels * P; cp++) {
        const float *h = Hm.response(cp / P, cp % P);
        float *out = R.data.data() + cp * H.samples;
        for (std::size_t s = 0; s < H.samples; s++)
            out[s] = static_cast<float>(sample_at(Hm, h, s, H.rate_hz));
    }
    return R;
}

TransferMatrix average(const TransferMatrix &H, const std::vector<Member> &members)
{
    TransferMatrix A;
    A.channels = H.channels;
    A.samples = H.samples;
    A.decimation = H.decimation;
    A.time_step_s = H.time_step_s;
    A.rate_hz = H.rate_hz;
    A.exciters = H.exciters;
    A.points.assign(H.points.begin() + std::ptrdiff_t(H.exact_begin()), H.points.end());
    const std::size_t C = A.channels, F = A.points.size(), S = A.samples;
    std::vector<double> sum(C * F * S);
    for (std::size_t c = 0; c < C; c++)
        for (std::size_t f = 0; f < F; f++) {
            const float *h = H.response(c, H.exact_begin() + f);
            for (std::size_t s = 0; s < S; s++)
                sum[(c * F + f) * S + s] = h[s];
        }
    for (const Member &m : members) {
        const TransferMatrix &Hm = m.H;
        for (std::size_t c = 0; c < C; c++)
            for (std::size_t f = 0; f < F; f++) {
                const float *h = Hm.response(c, Hm.exact_begin() + f);
                double *acc = &sum[(c * F + f) * S];
                for (std::size_t s = 0; s < S; s++) // at H's rate
                    acc[s] += sample_at(Hm, h, s, H.rate_hz);
            }
    }
    const double n = double(members.size() + 1);
    A.data.resize(sum.size());
    for (std::size_t i = 0; i < sum.size(); i++)
        A.data[i] = static_cast<float>(sum[i] / n);
    return A;
}

} // namespace

TransferMatrix ensemble_transfer(const CalibrationInput &in, const TransferMatrix &H,
                                 const std::vector<Perturbation> &members, const ProgressFn &progress)
{
    return average(H, simulate_members(in, H, members, false, progress));
}

RobustDesign robust_design(const CalibrationInput &in, const TransferMatrix &H, const ProgressFn &progress)
{
    const auto t0 = std::chrono::steady_clock::now();
    const RobustSpec spec = in.robust.value_or(RobustSpec{});
    RobustDesign d;
    d.members = ensemble_members(in, spec);
    // The inverse filter's objective covers the whole active area: every
    // member is simulated with the observation lattice (time reversal needs it
    // only for the margin level).
    const bool inverse = in.calibration.method == DriveMethod::inverse_filter;
    const std::vector<Member> plates = simulate_members(in, H, d.members, spec.margin_level || inverse, progress);
    if (inverse) {
        std::vector<TransferMatrix> resampled; // members at another rate, at H's
        resampled.reserve(plates.size());
        Plates stack{&H};
        for (const Member &m : plates) {
            check_same_points(m.H, H);
            if (m.H.rate_hz == H.rate_hz && m.H.samples == H.samples) {
                stack.push_back(&m.H);
                continue;
            }
            resampled.push_back(at_rate_of(m.H, H));
            stack.push_back(&resampled.back());
        }
        d.signals = inverse_filter_signals(in, stack);
    } else {
        // Time reversal of the members' average; its exciter gains judged on
        // the nominal plate's lattice (the average keeps the foci only).
        d.signals = signals_from_transfer(in, average(H, plates), {}, &H);
    }
    if (spec.margin_level) {
        // Full-scale playback on every plate: the weakest focal peak P and the
        // strongest displacement elsewhere G per focus; linearity gives the level.
        const std::vector<std::vector<int16_t>> q = stored_samples(d.signals);
        const double rate = in.calibration.output_rate_hz, T = in.calibration.threshold_m;
        const Verification v0 = verify_signals_with(in, H, q, rate);
        std::vector<double> P(q.size()), G(q.size()), nominal(q.size());
        for (std::size_t f = 0; f < q.size(); f++) {
            nominal[f] = P[f] = v0.foci[f].peak_m;
            G[f] = std::max(v0.foci[f].max_whole_area_m, v0.foci[f].max_other_foci_m);
        }
        for (const Member &m : plates) {
            const Verification v = verify_signals_with(m.in, m.H, q, rate);
            for (std::size_t f = 0; f < q.size(); f++) {
                P[f] = std::min(P[f], v.foci[f].peak_m);
                G[f] = std::max(G[f], std::max(v.foci[f].max_whole_area_m, v.foci[f].max_other_foci_m));
            }
        }
        for (std::size_t f = 0; f < q.size(); f++) // level g = T / sqrt(P G) of full scale, as a nominal amplitude
            d.amplitude_m.push_back(nominal[f] * T / std::sqrt(P[f] * G[f]));
    }
    d.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return d;
}

} // namespace calib::pipeline
