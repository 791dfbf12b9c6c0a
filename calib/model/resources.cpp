#include "model/resources.h"

#include <malloc.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

namespace calib::model {

namespace {

std::string fmt(const char *f, double v)
{
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

// A /proc/self/status field in kB, as MB.
double status_mb(const std::string &key)
{
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind(key, 0) == 0)
            return std::strtod(line.c_str() + key.size(), nullptr) / 1024.0;
    return 0;
}

}  // namespace

Limits machine_limits(std::optional<double> max_memory_mb, std::optional<double> max_seconds)
{
    Limits l;
    if (max_memory_mb) {
        if (!(*max_memory_mb > 0) || !std::isfinite(*max_memory_mb))
            throw std::invalid_argument("--max-memory: must be a positive number of MB");
        l.memory_mb = *max_memory_mb;
        l.memory_source = "--max-memory";
    } else {
        const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
        l.memory_mb = pages > 0 && page > 0 ? double(pages) * double(page) / (1024.0 * 1024.0) : INFINITY;
        l.memory_source = "physical memory; --max-memory sets it";
    }
    if (max_seconds) {
        if (!(*max_seconds > 0))
            throw std::invalid_argument("--max-seconds: must be a positive number of seconds");
        l.seconds = *max_seconds;
    }
    return l;
}

void refuse_if_over(const std::string &what, double memory_mb, double seconds, const Limits &limits,
                    const std::string &cause_key)
{
    const bool memory = !(memory_mb <= limits.memory_mb);
    const bool time = limits.seconds && !(seconds <= *limits.seconds);
    if (!memory && !time)
        return;
    std::string limit = memory ? "over this machine's " + fmt("%.0f MB", limits.memory_mb) + " (" +
                                     limits.memory_source + ")"
                               : "over the time limit of " + fmt("%g s", *limits.seconds) + " (--max-seconds)";
    throw std::runtime_error(what + ": refused before simulating: predicted " + fmt("%.0f MB", memory_mb) +
                             " peak memory and " + fmt("%.3g s", seconds) + ", " + limit + "; " + cause_key);
}

std::string calibration_cause(const pipeline::CalibrationInput &in, const pipeline::CalibrationPlan &plan,
                              const Prediction &p, bool verification_only)
{
    if (!verification_only && p.traces_mb + p.recordings_mb >= p.fields_mb) {
        const std::string sites = fmt("%.0f", double(plan.sites.size())) + " candidate sites x " +
                                  fmt("%.0f", double(plan.window_steps)) + " steps of recordings";
        if (in.exciters.site_spacing_m)
            return sites + ": raise exciters.site_spacing_m (" + fmt("%g m", *in.exciters.site_spacing_m) +
                   ") or shorten calibration.window_s";
        return sites + " (sites lambda/8 = " + fmt("%.3g mm", plan.site_spacing_m * 1e3) +
               " apart): lower pulse.centre_hz (" + fmt("%g Hz", in.pulse.centre_hz) +
               ") or set exciters.site_spacing_m";
    }
    const engine::Grid &g = in.plate->grid();
    return fmt("%.0f", double(plan.window_steps)) + " steps per window on a grid of " + std::to_string(g.nx) + " x " + std::to_string(g.ny) + " cells of " +
           fmt("%.3g mm", g.h * 1e3) + ": lower simulation.points_per_wavelength or simulation.f_max_hz";
}

Priced refuse_unaffordable(const pipeline::CalibrationInput &in, const Limits &limits, const std::string &what,
                           bool verification_only)
{
    Priced r{pipeline::plan(in), {}};
    auto price = [&](const CostModel *c) {
        return verification_only ? predict_verification(in, r.plan, c) : predict(in, r.plan, c);
    };
    r.prediction = price(nullptr);
    if (r.prediction.memory_mb <= limits.memory_mb && !limits.seconds)
        return r;
    // A time for the message, or for the limit: a reduced timing of the
    // scene's operator (its fields fit, or the memory test would not have
    // passed the grid check in build_plate).
    const CostModel cost = measure_cost(in, r.plan, 2e6);
    r.prediction = price(&cost);
    refuse_if_over(what, r.prediction.memory_mb, r.prediction.seconds, limits,
                   calibration_cause(in, r.plan, r.prediction, verification_only));
    return r;
}

double current_rss_mb() { return status_mb("VmRSS:"); }

double peak_rss_mb() { return status_mb("VmHWM:"); }

void reset_peak_rss()
{
    malloc_trim(0);  // hand freed heap back, so the peak counts what the next run needs
    std::ofstream f("/proc/self/clear_refs");
    f << "5";  // resets VmHWM (Linux >= 4.0)
}

}  // namespace calib::model
