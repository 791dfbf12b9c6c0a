#include "pipeline/calibrate.h"

#include "pipeline/calibrate_stages.h"
#include "pipeline/data/lead_time.h"
#include "pipeline/placement_search.h"
#include "pipeline/placement_verdict.h"
#include "pipeline/plan.h"
#include "pipeline/robustness/robust_design.h"
#include "pipeline/robustness/tolerance.h"
#include "pipeline/transfer/transfer.h"
#include "io/format.h"
#include "physics/dispersion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

} // namespace

void check_feasible(const CalibrationInput &in)
{
    const auto &pp = in.plate->params();
    const double lx = pp.size_x_m, ly = pp.size_y_m;
    if (in.foci.points.empty())
        throw std::invalid_argument("foci: no focus points");
    for (size_t k = 0; k < in.foci.points.size(); k++) {
        const Point p = in.foci.points[k].at;
        if (!(p.x_m > 0 && p.x_m < lx && p.y_m > 0 && p.y_m < ly))
            throw std::invalid_argument(
                "foci: focus " + std::to_string(in.foci.points[k].id) +
                io::fmt(" at (%g, %g) m is not inside the plate (0...%g, 0...%g)", p.x_m, p.y_m, lx, ly));
    }
    // Foci are where a person touches: inside the active area.
    const Rect &area = in.active.area;
    for (size_t k = 0; k < in.foci.points.size(); k++) {
        const Point p = in.foci.points[k].at;
        if (!area.contains(p, 1e-9))
            throw std::invalid_argument("foci.points_m: focus " + std::to_string(in.foci.points[k].id) +
                                        io::fmt(" at (%g, %g) m is outside the active area [%g, %g, %g, %g]", p.x_m,
                                                p.y_m, area.x0_m, area.y0_m, area.x1_m, area.y1_m));
    }
    // Foci closer than one cell of the plate grid are not distinct points of
    // the simulated plate (the source and receiver of each sit on its nodes).
    const double h = in.plate->grid().h;
    if (in.foci.pitch_m && *in.foci.pitch_m < h)
        throw std::invalid_argument(
            io::fmt("foci.pitch_m: %g m is finer than the simulation grid spacing (%g m)", *in.foci.pitch_m, h) +
            ": foci closer than one grid cell are not distinct on the simulated plate");
    const Rect &a = in.active.area;
    if (!(a.x0_m < a.x1_m && a.y0_m < a.y1_m && a.x0_m >= 0 && a.y0_m >= 0 && a.x1_m <= lx && a.y1_m <= ly))
        throw std::invalid_argument("active_area: the rectangle must lie on the plate with x0 < x1 and y0 < y1");
    const double crossing =
        std::hypot(lx, ly) / physics::kirchhoff_group_velocity_m_s(in.plate->kappa(), in.pulse.centre_hz);
    if (in.calibration.window_s < crossing)
        throw std::invalid_argument(
            io::fmt("calibration.window_s: %g s is shorter than one crossing of the plate (%g s",
                    in.calibration.window_s, crossing) +
            " along the diagonal at the A0 group velocity)");
    if (in.calibration.window_s * in.calibration.truncate_fraction < pulse_duration_s(in.pulse))
        throw std::invalid_argument(
            "calibration.truncate_fraction: the kept part of the window is shorter than the pulse");
    if (in.tolerance)
        check_tolerance(in, *in.tolerance);
    if (in.robust)
        ensemble_members(in, *in.robust); // refuses members the scheme cannot take
    const Band band = band_of(in);
    check_lead_time(in, in.exciters.placement == PlacementMode::fixed ? in.exciters.positions : plan(in).sites);
    if (in.exciters.placement == PlacementMode::fixed) {
        if (in.exciters.positions.size() != in.exciters.count)
            throw std::invalid_argument("exciters.positions: " + std::to_string(in.exciters.positions.size()) +
                                        " positions for exciters.count = " + std::to_string(in.exciters.count));
        for (size_t k = 0; k < in.exciters.positions.size(); k++)
            if (!band.allows(in.exciters.positions[k]))
                throw std::invalid_argument("exciters.positions[" + std::to_string(k) +
                                            "]: inside the active area, its clearance or the frame margin");
        return;
    }
    const std::vector<Point> sites = plan(in).sites;
    // Greedy packing at the minimum spacing: if it cannot place them, no search can.
    std::vector<Point> placed;
    for (Point s : sites) {
        bool ok = true;
        for (Point p : placed)
            ok &= dist(p, s) >= in.exciters.min_spacing_m;
        if (ok)
            placed.push_back(s);
    }
    if (placed.size() < in.exciters.count)
        throw std::invalid_argument("exciters.count: the border band (frame_margin_m, clearance_m around the active "
                                    "area) holds only " +
                                    std::to_string(placed.size()) + " exciters " +
                                    io::fmt("%g", in.exciters.min_spacing_m) + " m apart, " +
                                    std::to_string(in.exciters.count) + " asked");
}

CalibrationResult calibrate(const CalibrationInput &in, const ProgressFn &progress)
{
    check_feasible(in);
    const CalibrationPlan plan = pipeline::plan(in);
    CalibrationResult res;

    // 1-2. Responses of the placement's emitters (the foci of its subset and
    //      any probe points) and the placement search.
    PlacementSearch search(in, plan, progress, res);
    res.placement.focus_subset = plan.focus_subset;
    res.placement.subset_cover_m = plan.subset_cover_m;
    res.placement.simulations = plan.emitters.size();

    // 2-5. A searched placement is judged by the verdict of its own drives
    //      (placement_verdict.h): the transfer matrix, signals and
    //      verification of the best one judged stay.
    if (judged_by_verdict(in, search)) {
        const TransferMatrix H = search_by_verdict(in, search, progress, res);
        if (in.robust) // the robust design of the placement the plain design chose
            signals_and_verification(in, H, progress, res);
        else
            finish_stages(in, H, progress, res);
        return res;
    }

    // 3. The transfer matrix of the placed exciters (the finger is composed in
    //    playback only, so H of the bare plate also serves the finger's scenes).
    auto t0 = Clock::now();
    const TransferMatrix H = transfer_for(in, res.exciters, progress);
    res.transfer = transfer_summary(H);
    res.times.transfer_s = seconds_since(t0);

    // 4-5. Drive signals from H, their level and the verification.
    signals_and_verification(in, H, progress, res);
    return res;
}

} // namespace calib::pipeline
