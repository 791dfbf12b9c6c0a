#include "pipeline/plan.h"

#include "physics/dispersion.h"
#include "pipeline/data/lead_time.h"
#include "pipeline/placement/focus_subset.h"
#include "pipeline/placement/placement.h"
#include "pipeline/placement/site_recording.h"
#include "pipeline/signal/pulse.h"
#include "pipeline/transfer/transfer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

// Probe points where a lone focus must stay above the field: a 3 x 3 grid
// over the active area, without the points within half a wavelength of a
// focus. With four foci or more, the other foci already sample the field.
std::vector<Point> probe_points(const CalibrationInput &in, double lambda_half)
{
    std::vector<Point> probes;
    if (in.foci.points.size() >= 4)
        return probes;
    const Rect &a = in.active.area;
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 3; i++) {
            Point p{a.x0_m + (a.x1_m - a.x0_m) * (1 + 2 * i) / 6.0, a.y0_m + (a.y1_m - a.y0_m) * (1 + 2 * j) / 6.0};
            bool near = false;
            for (const FocusPoint &f : in.foci.points)
                near |= dist(p, f.at) < lambda_half;
            if (!near)
                probes.push_back(p);
        }
    return probes;
}

std::size_t steps_for(double duration_s, double k)
{
    return static_cast<std::size_t>(std::ceil(duration_s / k - 1e-9)); // as engine::Simulation::steps_for
}

} // namespace

double lattice_points(const Band &band, double spacing_m)
{
    return (std::floor(band.plate_x_m / spacing_m) + 1) * (std::floor(band.plate_y_m / spacing_m) + 1);
}

CalibrationPlan plan(const CalibrationInput &in)
{
    CalibrationPlan p;
    p.band = band_of(in);
    p.lambda_centre_m = physics::kirchhoff_wavelength_m(in.plate->kappa(), in.pulse.centre_hz);
    const bool fixed = in.exciters.placement == PlacementMode::fixed;
    if (fixed) {
        p.sites = in.exciters.positions;
    } else {
        p.site_spacing_m = in.exciters.site_spacing_m.value_or(p.lambda_centre_m / 8);
        const double lattice = lattice_points(p.band, p.site_spacing_m);
        if (!(lattice <= max_candidate_sites)) {
            char b[256];
            std::snprintf(b, sizeof b,
                          "%s: a candidate lattice of %.3g points (%.3g m apart on a %.3g x %.3g m plate) is more than "
                          "the %.0e a placement search can visit",
                          in.exciters.site_spacing_m ? "exciters.site_spacing_m" : "pulse.centre_hz (lambda/8 apart)",
                          lattice, p.site_spacing_m, p.band.plate_x_m, p.band.plate_y_m, max_candidate_sites);
            throw std::invalid_argument(b);
        }
        p.sites = candidate_sites(p.band, p.site_spacing_m);
    }
    p.search_rate_hz = search_rate(in.pulse);
    { // The placement search weighs a bounded subset of the foci (placement/focus_subset.h).
        std::vector<Point> at;
        for (const FocusPoint &f : in.foci.points)
            at.push_back(f.at);
        p.placement_focus_cap = placement_focus_cap(
            in.exciters.placement_foci, double(p.sites.size()),
            contrast_model_lags(in.calibration.window_s, in.calibration.truncate_fraction, p.search_rate_hz));
        FocusSubset s = farthest_point_subset(at, p.placement_focus_cap, p.lambda_centre_m / 2);
        std::sort(s.members.begin(), s.members.end());
        p.focus_subset = s.members;
        p.subset_cover_m = s.covering_radius_m;
        for (std::size_t i : p.focus_subset)
            p.emitters.push_back(at[i]);
    }
    p.foci = p.emitters.size();
    if (!fixed) {
        const std::vector<Point> probes = probe_points(in, p.lambda_centre_m / 2);
        p.emitters.insert(p.emitters.end(), probes.begin(), probes.end());
    }

    p.nodes = in.plate->grid().node_count();
    p.time_step_s =
        in.simulation.time_step_s > 0 ? in.simulation.time_step_s : in.simulation.courant * in.plate->max_time_step();
    p.window_steps = steps_for(in.calibration.window_s, p.time_step_s);
    const SiteRecordingOptions sro = site_recording_options(p.time_step_s, p.search_rate_hz);
    p.site_decimation = sro.decimation;
    p.site_steps = p.window_steps + site_recording_delay_steps(p.time_step_s, sro);
    // The drive is the kept part of the window (design/time_reversal.cpp), then the tail.
    p.drive_steps = steps_for(kept_window_s(in) + in.calibration.verify_tail_s, p.time_step_s);
    p.transfer = transfer_holds(in);
    if (!p.transfer)
        p.verification = {{true, false}, {false, true}};
    const TransferOptions t = transfer_options(in, p.time_step_s);
    const ObservationLattice lat = observation_lattice(in, t.lattice_stride);
    p.transfer_steps = t.samples * t.decimation;
    p.transfer_bytes =
        double(in.exciters.count) * double(lat.size() + in.foci.points.size()) * double(t.samples) * sizeof(float);
    return p;
}

} // namespace calib::pipeline
