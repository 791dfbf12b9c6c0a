#include "pipeline/robustness/tolerance.h"

#include "io/format.h"
#include "pipeline/transfer/transfer.h"
#include "pipeline/verification/drive_figures.h"
#include "pipeline/verification/verification.h"

#include <haptic_stretch.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <random>
#include <stdexcept>
#include <utility>

namespace calib::pipeline {

namespace {

using io::fmt;

// The scene key each factor comes from, for refusals.
std::string key_of(const std::string &factor)
{
    static const std::pair<const char *, const char *> keys[] = {{"E", "E_rel"},
                                                                 {"rho", "rho_rel"},
                                                                 {"thickness", "thickness_rel"},
                                                                 {"loss", "loss"},
                                                                 {"loss scale", "loss_scale"},
                                                                 {"temperature", "temperature_k"},
                                                                 {"exciters", "exciter_position_m"}};
    for (const auto &[f, key] : keys)
        if (factor == f)
            return std::string("tolerance.") + key;
    return "tolerance";
}

// Uniform in [0, 1) from a 64-bit generator (the same on every platform).
double uniform(std::mt19937_64 &g) { return double(g() >> 11) * 0x1p-53; }

Perturbation scaled(const std::string &name, const std::string &factor, double youngs, double density, double thickness)
{
    Perturbation p;
    p.name = name;
    p.factor = factor;
    p.youngs_scale = youngs;
    p.density_scale = density;
    p.thickness_scale = thickness;
    return p;
}

std::string percent(double rel) { return fmt("%+g %%", 100 * rel); }

} // namespace

double loss_factor(const engine::PlateOperator &plate, double f_hz)
{
    const engine::Loss &l = plate.params().loss;
    const double omega = 2 * std::numbers::pi * f_hz;
    return 2 * l.decay_rate_1_s(omega, plate.kappa()) / omega;
}

ResolvedTolerance resolve_tolerance(const CalibrationInput &in, const ToleranceSpec &t)
{
    ResolvedTolerance r;
    r.spec = t;
    r.nominal_loss = loss_factor(*in.plate, in.pulse.centre_hz);
    const physics::Material &m = in.plate->params().material;
    if (!r.spec.loss_min && m.loss_factor_max > 0) {
        r.spec.loss_min = m.loss_factor_min;
        r.spec.loss_max = m.loss_factor_max;
    }
    r.loss_range = r.spec.loss_min && r.spec.loss_max && r.nominal_loss > 0;
    r.youngs_per_kelvin = panel_youngs_per_kelvin(&t, m);
    return r;
}

void check_tolerance(const CalibrationInput &in, const ToleranceSpec &t)
{
    if (!transfer_holds(in))
        throw std::invalid_argument("tolerance: the tolerance box is verified through the transfer matrix, which "
                                    "does not hold with [effects.finger]");
    const ResolvedTolerance r = resolve_tolerance(in, t);
    if (t.loss_min && !(r.nominal_loss > 0))
        throw std::invalid_argument("tolerance.loss: the plate has no loss ([plate.loss]) to vary");
    if (!t.loss_scale.empty() && !(r.nominal_loss > 0))
        throw std::invalid_argument("tolerance.loss_scale: the plate has no loss ([plate.loss]) to scale");
    auto positive = [](double v, const char *key, const std::string &what) {
        if (!(v > 0 && std::isfinite(v)))
            throw std::invalid_argument(std::string(key) + ": makes " + what + " " + fmt("%g", v) +
                                        " times the nominal (a plate needs it positive)");
    };
    positive(1 - t.youngs_rel, "tolerance.E_rel", "Young's modulus");
    positive(1 - t.density_rel, "tolerance.rho_rel", "the density");
    positive(1 - t.thickness_rel, "tolerance.thickness_rel", "the thickness");
    positive(1 - std::abs(r.youngs_per_kelvin) * t.temperature_k, "tolerance.temperature_k", "Young's modulus");
    if (t.speed_compensation) {
        // The device stretches by 0.8-1.25 (common/haptic_stretch.h): every
        // plate of the box, the corners of the random combinations included.
        std::vector<Perturbation> plates = one_at_a_time(in, t);
        if (t.random_cases > 0) {
            const double T = std::abs(r.youngs_per_kelvin) * t.temperature_k;
            plates.push_back(scaled("the slowest corner of the random combinations", "", (1 - t.youngs_rel) * (1 - T),
                                    1 + t.density_rel, 1 - t.thickness_rel));
            plates.push_back(scaled("the fastest corner of the random combinations", "", (1 + t.youngs_rel) * (1 + T),
                                    1 - t.density_rel, 1 + t.thickness_rel));
        }
        for (const Perturbation &p : plates) {
            const double alpha = p.thickness_scale * std::sqrt(p.youngs_scale / p.density_scale);
            if (!(alpha >= HAPTIC_STRETCH_MIN_RATIO && alpha <= HAPTIC_STRETCH_MAX_RATIO))
                throw std::invalid_argument("tolerance.speed_compensation: " + p.name + " makes the response run " +
                                            fmt("%.3f", alpha) + " times as fast, beyond what a device stretches (" +
                                            fmt("%g", HAPTIC_STRETCH_MIN_RATIO) + "-" +
                                            fmt("%g", HAPTIC_STRETCH_MAX_RATIO) + ")");
        }
    }
    // Every plate of the box must take the scheme: each case, and the corner
    // where the plate is stiffest and most lossy (the random combinations
    // stay inside it). Only a forced time step can fail; otherwise a plate
    // whose bound the nominal step passes gets its own.
    if (!(in.simulation.time_step_s > 0) || in.effects.thick_plate)
        return; // each plate then takes its own stable step: nothing to build here
    std::vector<Perturbation> cases = one_at_a_time(in, t);
    if (t.random_cases > 0) {
        Perturbation corner = scaled("the stiffest, most lossy corner of the random combinations", "", 1 + t.youngs_rel,
                                     1 - t.density_rel, 1 + t.thickness_rel);
        corner.youngs_scale *= 1 + std::abs(r.youngs_per_kelvin) * t.temperature_k;
        for (const Perturbation &p : cases)
            if (p.factor == "loss")
                corner.loss_scale = std::max(corner.loss_scale, p.loss_scale);
        cases.push_back(corner);
    }
    for (const Perturbation &p : cases) {
        try {
            perturbed_input(in, p);
        } catch (const std::invalid_argument &e) {
            throw std::invalid_argument(key_of(p.factor) + ": " + p.name + ": " + e.what());
        }
    }
}

Perturbation loss_case(const CalibrationInput &in, double eta, const std::string &factor)
{
    Perturbation p;
    p.name = "loss " + fmt("%.3f", eta);
    p.factor = factor;
    p.loss_scale = eta / loss_factor(*in.plate, in.pulse.centre_hz);
    return p;
}

std::vector<Perturbation> one_at_a_time(const CalibrationInput &in, const ToleranceSpec &t)
{
    const ResolvedTolerance r = resolve_tolerance(in, t);
    std::vector<Perturbation> out;
    if (t.youngs_rel > 0)
        for (double s : {-1.0, 1.0})
            out.push_back(scaled("E " + percent(s * t.youngs_rel), "E", 1 + s * t.youngs_rel, 1, 1));
    if (t.density_rel > 0)
        for (double s : {-1.0, 1.0})
            out.push_back(scaled("rho " + percent(s * t.density_rel), "rho", 1, 1 + s * t.density_rel, 1));
    if (t.thickness_rel > 0)
        for (double s : {-1.0, 1.0})
            out.push_back(scaled("d " + percent(s * t.thickness_rel), "thickness", 1, 1, 1 + s * t.thickness_rel));
    if (r.loss_range) {
        out.push_back(loss_case(in, *r.spec.loss_min, "loss"));
        out.push_back(loss_case(in, *r.spec.loss_max, "loss"));
    }
    if (r.nominal_loss > 0)
        for (double s : t.loss_scale) {
            Perturbation p;
            p.name = "loss x" + fmt("%g", s);
            p.factor = "loss scale";
            p.loss_scale = s;
            out.push_back(p);
        }
    if (t.exciter_position_m > 0) {
        std::mt19937_64 g(t.seed * 0x9e3779b97f4a7c15ULL + 17);
        std::vector<Point> a;
        for (unsigned c = 0; c < in.exciters.count; c++) {
            const double th = 2 * std::numbers::pi * uniform(g);
            a.push_back({t.exciter_position_m * std::cos(th), t.exciter_position_m * std::sin(th)});
        }
        const std::string mm = fmt("%g mm", t.exciter_position_m * 1e3);
        for (double s : {1.0, -1.0}) {
            Perturbation p;
            p.name = "exciters " + mm + (s > 0 ? " (a)" : " (b, opposite)");
            p.factor = "exciters";
            for (Point o : a)
                p.exciter_offsets_m.push_back({s * o.x_m, s * o.y_m});
            out.push_back(p);
        }
    }
    if (t.temperature_k > 0 && r.youngs_per_kelvin != 0)
        for (double s : {-1.0, 1.0}) {
            Perturbation p = scaled("T " + fmt("%+g K", s * t.temperature_k), "temperature",
                                    1 + r.youngs_per_kelvin * s * t.temperature_k, 1, 1);
            p.temperature_k = s * t.temperature_k;
            out.push_back(p);
        }
    return out;
}

std::vector<Perturbation> random_combinations(const CalibrationInput &in, const ToleranceSpec &t, unsigned n,
                                              uint64_t seed)
{
    const ResolvedTolerance r = resolve_tolerance(in, t);
    std::mt19937_64 g(seed * 0x9e3779b97f4a7c15ULL + 101);
    auto within = [&](double half) { return half * (2 * uniform(g) - 1); };
    std::vector<Perturbation> out;
    for (unsigned i = 0; i < n; i++) {
        Perturbation p = scaled("random " + std::to_string(i + 1), "combined", 1 + within(t.youngs_rel),
                                1 + within(t.density_rel), 1 + within(t.thickness_rel));
        if (r.loss_range) {
            const double eta = *r.spec.loss_min + (*r.spec.loss_max - *r.spec.loss_min) * uniform(g);
            p.loss_scale = eta / r.nominal_loss;
        }
        p.temperature_k = within(t.temperature_k);
        p.youngs_scale *= 1 + r.youngs_per_kelvin * p.temperature_k;
        if (t.exciter_position_m > 0)
            for (unsigned c = 0; c < in.exciters.count; c++) {
                const double rad = t.exciter_position_m * std::sqrt(uniform(g)); // uniform over the disc
                const double th = 2 * std::numbers::pi * uniform(g);
                p.exciter_offsets_m.push_back({rad * std::cos(th), rad * std::sin(th)});
            }
        out.push_back(p);
    }
    return out;
}

CalibrationInput perturbed_input(const CalibrationInput &in, const Perturbation &p)
{
    if (!(p.youngs_scale > 0 && p.density_scale > 0 && p.thickness_scale > 0 && p.loss_scale >= 0))
        throw std::invalid_argument("a plate needs positive E, rho and thickness and a non-negative loss");
    engine::PlateParams pp = in.plate->params();
    pp.material.youngs_pa *= p.youngs_scale;
    pp.material.density_kg_m3 *= p.density_scale;
    pp.thickness_m *= p.thickness_scale;
    // sigma(omega) = sigma0 + sigma1 omega / kappa: the same loss law on a
    // plate of another kappa has sigma1 in proportion to kappa.
    const double kappa_ratio = pp.material.kappa(pp.thickness_m) / in.plate->kappa();
    pp.loss.sigma0 *= p.loss_scale;
    pp.loss.sigma1 *= p.loss_scale * kappa_ratio;
    CalibrationInput out = in;
    out.lambda_half_m = judged_lambda_half_m(in); // judged on the scene's area, whatever the plate
    auto op = std::make_shared<const engine::PlateOperator>(pp, in.plate->grid());
    if (!in.effects.thick_plate) {
        if (in.simulation.time_step_s > 0) {
            engine::check_stable_time_step(*op, in.simulation.time_step_s); // the scene forced it
        } else {
            // The nominal step while this plate takes it with a margin.
            const double k = in.simulation.courant * in.plate->max_time_step();
            if (k <= 0.99 * op->max_time_step())
                out.simulation.time_step_s = k;
        }
    }
    out.plate = std::move(op);
    return out;
}

std::vector<Point> moved_exciters(const CalibrationInput &in, const std::vector<Point> &exciters, const Perturbation &p)
{
    std::vector<Point> out = exciters;
    const engine::Grid &g = in.plate->grid();
    for (std::size_t c = 0; c < out.size() && c < p.exciter_offsets_m.size(); c++) {
        out[c].x_m = std::clamp(out[c].x_m + p.exciter_offsets_m[c].x_m, 0.0, g.length_x_m());
        out[c].y_m = std::clamp(out[c].y_m + p.exciter_offsets_m[c].y_m, 0.0, g.length_y_m());
    }
    return out;
}

TransferMatrix perturbed_transfer(const CalibrationInput &nominal, const CalibrationInput &perturbed,
                                  const std::vector<Point> &exciters, bool lattice, const ProgressFn &progress)
{
    engine::Simulation probe(perturbed.plate, single_core_options(perturbed));
    TransferOptions o = transfer_options(perturbed, probe.time_step_s());
    // The nominal lattice: every plate's whole-area figures on the same points.
    o.lattice_stride = lattice ? transfer_options(nominal, probe.time_step_s()).lattice_stride : 0;
    std::vector<Point> foci;
    for (const FocusPoint &f : perturbed.foci.points)
        foci.push_back(f.at);
    TransferMatrix H = simulate_transfer(perturbed, exciters, foci, o, [&](std::size_t done, std::size_t total) {
        if (progress)
            progress("transfer", done, total);
    });
    apply_force_gains(perturbed, H);
    return H;
}

std::optional<TransferMatrix> rescaled_transfer(const CalibrationInput &nominal, const CalibrationInput &perturbed,
                                                const TransferMatrix &H, const Perturbation &p)
{
    bool moved = false;
    for (Point o : p.exciter_offsets_m)
        moved = moved || o.x_m != 0 || o.y_m != 0;
    const engine::PlateParams &a = nominal.plate->params(), &b = perturbed.plate->params();
    if (nominal.effects.thick_plate || moved || p.loss_scale != 1 || a.material.poisson != b.material.poisson)
        return std::nullopt;
    const double alpha = perturbed.plate->kappa() / nominal.plate->kappa();
    // sigma0 would have to scale with alpha: only a negligible sigma0 allows it.
    const double sigma_centre =
        loss_factor(*nominal.plate, nominal.pulse.centre_hz) * std::numbers::pi * nominal.pulse.centre_hz;
    if (a.loss.sigma0 != 0 && std::abs(a.loss.sigma0 * (alpha - 1)) > 1e-9 * sigma_centre)
        return std::nullopt;
    TransferMatrix R = H;
    const double mass_ratio = (a.material.density_kg_m3 * a.thickness_m) / (b.material.density_kg_m3 * b.thickness_m);
    const auto g = static_cast<float>(mass_ratio / alpha);
    for (float &v : R.data)
        v *= g;
    R.time_step_s = H.time_step_s / alpha;
    R.rate_hz = H.rate_hz * alpha;
    return R;
}

std::vector<std::vector<int16_t>> stretched(const std::vector<std::vector<int16_t>> &signals, std::size_t channels,
                                            double speed_ratio)
{
    std::vector<std::vector<int16_t>> out;
    for (const std::vector<int16_t> &s : signals) {
        const auto frames = static_cast<uint32_t>(s.size() / std::max<std::size_t>(channels, 1));
        std::vector<int16_t> t(std::size_t(haptic_stretch_frames(frames, speed_ratio)) * channels);
        if (t.empty())
            throw std::invalid_argument("speed compensation: a speed ratio of " + fmt("%.4f", speed_ratio) +
                                        " is beyond what a device stretches (" + fmt("%g", HAPTIC_STRETCH_MIN_RATIO) +
                                        "-" + fmt("%g", HAPTIC_STRETCH_MAX_RATIO) + ")");
        if (const int rc =
                haptic_stretch(s.data(), frames, static_cast<uint32_t>(channels), speed_ratio, t.data(), nullptr);
            rc != 0)
            throw std::runtime_error("speed compensation: the resampler failed (" + std::string(std::strerror(-rc)) +
                                     ")");
        out.push_back(std::move(t));
    }
    return out;
}

CaseFigures figures_of(const Verification &v, const std::vector<std::vector<int16_t>> &signals,
                       double force_full_scale_n, double rate_hz)
{
    CaseFigures c;
    double ppe = 0;
    for (std::size_t f = 0; f < v.foci.size(); f++) {
        const FocusMetrics &m = v.foci[f];
        if (m.whole_area && m.whole_area_contrast_db < c.worst_whole_area_contrast_db) {
            c.worst_whole_area_contrast_db = m.whole_area_contrast_db;
            c.worst_focus_id = m.id;
        }
        c.min_peak_m = std::min(c.min_peak_m, m.peak_m);
        c.max_peak_m = std::max(c.max_peak_m, m.peak_m);
        c.max_offset_m = std::max(c.max_offset_m, m.perceived_offset_distance_m);
        c.max_lead_time_s = std::max(c.max_lead_time_s, m.lead_time_s);
        const bool holds = m.passes(); // the verdict (data/verdict.h)
        c.foci_passing += holds;
        c.foci_failing += !holds;
        c.area_crossings += m.whole_area && !m.whole_area_below_threshold;
        const double e = f < signals.size() ? drive_energy_n2s(signals[f], force_full_scale_n, rate_hz) : 0.0;
        if (e > 0)
            ppe += m.peak_m / std::sqrt(e);
    }
    if (!v.foci.empty())
        c.peak_per_energy = ppe / double(v.foci.size());
    return c;
}

CaseFigures worst_of(const std::vector<CaseFigures> &all)
{
    CaseFigures w;
    if (all.empty())
        return w;
    w.foci_passing = all.front().foci_passing;
    w.peak_per_energy = all.front().peak_per_energy;
    for (const CaseFigures &c : all) {
        if (c.worst_whole_area_contrast_db < w.worst_whole_area_contrast_db) {
            w.worst_whole_area_contrast_db = c.worst_whole_area_contrast_db;
            w.worst_focus_id = c.worst_focus_id;
        }
        w.min_peak_m = std::min(w.min_peak_m, c.min_peak_m);
        w.max_peak_m = std::max(w.max_peak_m, c.max_peak_m);
        w.max_offset_m = std::max(w.max_offset_m, c.max_offset_m);
        w.max_lead_time_s = std::max(w.max_lead_time_s, c.max_lead_time_s);
        w.foci_passing = std::min(w.foci_passing, c.foci_passing);
        w.foci_failing = std::max(w.foci_failing, c.foci_failing);
        w.area_crossings = std::max(w.area_crossings, c.area_crossings);
        w.peak_per_energy = std::min(w.peak_per_energy, c.peak_per_energy);
    }
    return w;
}

std::vector<ToleranceCase> evaluate_cases(const CalibrationInput &in, const std::vector<Point> &exciters,
                                          const std::vector<Perturbation> &cases, const StoredTable &table,
                                          const StoredTable *plain, const ProgressFn &progress,
                                          const TransferMatrix *nominal_H)
{
    using Clock = std::chrono::steady_clock;
    std::vector<ToleranceCase> out;
    for (std::size_t i = 0; i < cases.size(); i++) {
        if (progress)
            progress("tolerance", i, cases.size());
        const auto t0 = Clock::now();
        ToleranceCase c;
        c.perturbation = cases[i];
        const CalibrationInput pin = perturbed_input(in, cases[i]);
        std::optional<TransferMatrix> scaled;
        if (nominal_H)
            scaled = rescaled_transfer(in, pin, *nominal_H, cases[i]);
        c.rescaled = scaled.has_value();
        const TransferMatrix H =
            scaled ? std::move(*scaled) : perturbed_transfer(in, pin, moved_exciters(in, exciters, cases[i]), true);
        const double F = in.exciters.force_full_scale_n;
        c.table =
            figures_of(verify_signals_with(pin, H, table.signals, table.rate_hz), table.signals, F, table.rate_hz);
        if (plain)
            c.nominal_design = figures_of(verify_signals_with(pin, H, plain->signals, plain->rate_hz), plain->signals,
                                          F, plain->rate_hz);
        c.speed_ratio = pin.plate->kappa() / in.plate->kappa();
        if (in.tolerance && in.tolerance->speed_compensation && c.speed_ratio != 1) {
            // What the device plays on this panel (hapticd [panel]), verified.
            auto compensated = [&](const StoredTable &t) {
                const std::vector<std::vector<int16_t>> s = stretched(t.signals, in.exciters.count, c.speed_ratio);
                return figures_of(verify_signals_with(pin, H, s, t.rate_hz), s, F, t.rate_hz);
            };
            c.compensated = compensated(table);
            if (plain)
                c.nominal_design_compensated = compensated(*plain);
        }
        c.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
        out.push_back(std::move(c));
    }
    if (progress)
        progress("tolerance", cases.size(), cases.size());
    return out;
}

} // namespace calib::pipeline
