#include "pipeline/data/lead_time.h"

#include "io/format.h"
#include "physics/dispersion.h"
#include "pipeline/signal/pulse.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

std::string ms(double s) { return io::fmt("%.1f ms", s * 1e3); }

} // namespace

double pulse_peak_offset_s(const PulseSpec &p, double rate_hz)
{
    const std::vector<double> x = sample_pulse(p, rate_hz);
    std::size_t best = 0;
    for (std::size_t i = 0; i < x.size(); i++)
        if (std::abs(x[i]) >= std::abs(x[best]) * (1 + 1e-9))
            best = i;
    return std::abs(double(best) / rate_hz - pulse_duration_s(p) / 2);
}

double target_lead_time_s(const CalibrationInput &in)
{
    if (in.calibration.lead_time_s)
        return *in.calibration.lead_time_s;
    const double rate = search_rate(in.pulse);
    return in.calibration.truncate_fraction * in.calibration.window_s - pulse_duration_s(in.pulse) / 2 +
           pulse_peak_offset_s(in.pulse, rate);
}

double focus_centre_s(const CalibrationInput &in)
{
    return target_lead_time_s(in) - pulse_peak_offset_s(in.pulse, search_rate(in.pulse));
}

double kept_window_s(const CalibrationInput &in)
{
    if (!in.calibration.lead_time_s)
        return in.calibration.truncate_fraction * in.calibration.window_s;
    return focus_centre_s(in) + pulse_duration_s(in.pulse) / 2;
}

double kept_fraction(const CalibrationInput &in)
{
    if (!in.calibration.lead_time_s)
        return in.calibration.truncate_fraction;
    return kept_window_s(in) / in.calibration.window_s;
}

double crossing_time_s(const CalibrationInput &in, const std::vector<Point> &sites)
{
    double far = 0;
    for (Point s : sites)
        for (const FocusPoint &f : in.foci.points)
            far = std::max(far, dist(s, f.at));
    return far / physics::kirchhoff_group_velocity_m_s(in.plate->kappa(), in.pulse.centre_hz);
}

void check_lead_time(const CalibrationInput &in, const std::vector<Point> &sites)
{
    if (!in.calibration.lead_time_s)
        return;
    const double lead = *in.calibration.lead_time_s;
    const double crossing = crossing_time_s(in, sites);
    if (lead < crossing)
        throw std::invalid_argument("calibration.lead_time_s: " + ms(lead) + " is shorter than the plate crossing (" +
                                    ms(crossing) +
                                    " from the farthest exciter site to the farthest focus at the A0 group velocity)");
    if (kept_window_s(in) > in.calibration.window_s)
        throw std::invalid_argument("calibration.lead_time_s: " + ms(lead) + " and the pulse's second half (" +
                                    ms(kept_window_s(in)) + ") do not fit in calibration.window_s (" +
                                    ms(in.calibration.window_s) + ")");
}

} // namespace calib::pipeline
