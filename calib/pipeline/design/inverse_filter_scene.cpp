// The scene's inverse-filter designs: each focus's problem (its target, its
// control points, the drive's length), the foci designed together through
// the shared correlations, the finished drives, and the joint designs of
// several fingers.
#include "pipeline/design/inverse_filter.h"

#include "pipeline/data/lead_time.h"
#include "pipeline/design/finishing.h"
#include "pipeline/design/inverse_filter_solve.h"
#include "pipeline/design/shared_designs.h"
#include "pipeline/signal/pulse.h"

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

using inverse_solve::check_plates;

std::size_t scene_drive_samples(const CalibrationInput &in, double rate_hz)
{
    return static_cast<std::size_t>(
               std::floor((target_lead_time_s(in) + in.calibration.active_damping_s) * rate_hz + 1e-9)) +
           1;
}

std::vector<std::size_t> lattice_in_area(const CalibrationInput &in, const ObservationLattice &lattice)
{
    std::vector<std::size_t> q;
    for (std::size_t n = 0; n < lattice.size(); n++)
        if (in.active.area.contains(lattice.at(n)))
            q.push_back(n);
    return q;
}

namespace {

// The joint design's index for its dither seed: one no focus has.
constexpr uint64_t joint_drive = 999983;

// The scene's problem of the foci `set` (indices into the scene's foci) on H.
InverseFilterProblem scene_problem(const CalibrationInput &in, const TransferMatrix &H,
                                   const std::vector<std::size_t> &set)
{
    InverseFilterProblem p;
    p.drive_samples = scene_drive_samples(in, H.rate_hz);
    p.target = focus_target(in, H.rate_hz, focus_centre_s(in));
    for (std::size_t f : set)
        p.foci.push_back(H.exact_begin() + f);
    p.control = control_points(in, H, set);
    return p;
}

// Every point a scene's design can weigh: the lattice points in the active
// area and the foci (control_points draws from these).
std::vector<std::size_t> scene_points(const CalibrationInput &in, const TransferMatrix &H)
{
    std::vector<std::size_t> q = lattice_in_area(in, H.lattice);
    for (std::size_t g = 0; g < in.foci.points.size(); g++)
        if (H.exact_begin() + g < H.point_count())
            q.push_back(H.exact_begin() + g);
    return q;
}

// The scene's designs of `sets` (each a set of indices into the scene's
// foci) over `plates`. Shared: through SharedDesigns, the sets in parallel
// (Eigen then runs each design on one thread: the same arithmetic whichever
// sets are asked, so a set's design does not depend on the others);
// otherwise each from scratch (minimax_design). A failure names the set.
std::vector<InverseFilterDesign> scene_designs(const CalibrationInput &in, const Plates &plates,
                                               const std::vector<std::vector<std::size_t>> &sets,
                                               const std::vector<std::string> &names, bool shared,
                                               const ProgressFn &progress)
{
    check_plates(plates);
    const TransferMatrix &H = *plates.front();
    std::vector<InverseFilterDesign> out(sets.size());
    if (sets.empty())
        return out;
    std::unique_ptr<SharedDesigns> common;
    if (shared)
        common = std::make_unique<SharedDesigns>(plates, scene_points(in, H), scene_drive_samples(in, H.rate_hz));
    const InverseFilterOptions o = scene_inverse_filter_options(in);
    std::size_t done = 0;
    std::string failure;
    if (progress)
        progress("signals", 0, sets.size());
#pragma omp parallel for schedule(dynamic, 1) if (shared)
    for (std::size_t i = 0; i < sets.size(); i++) {
        try {
            InverseFilterProblem p = scene_problem(in, H, sets[i]);
            out[i] = common ? common->minimax(std::move(p), o) : minimax_design(plates, std::move(p), o);
        } catch (const std::exception &e) {
#pragma omp critical(inverse_filter_failure)
            if (failure.empty())
                failure = names[i] + ": " + e.what();
        }
#pragma omp critical(inverse_filter_progress)
        {
            done++;
            if (progress)
                progress("signals", done, sets.size());
        }
    }
    if (!failure.empty())
        throw std::runtime_error(failure);
    return out;
}

// The drive of a scene's design at full scale, finished with the scene's
// options for drive `drive` (finishing.h drive_options).
DriveSignals scene_signals(const CalibrationInput &in, const TransferMatrix &H, InverseFilterDesign d, uint64_t drive)
{
    // The focus instant from playback start, on H's sample grid (focus_target).
    const double delay =
        double(std::lround((focus_centre_s(in) - pulse_duration_s(in.pulse) / 2) * H.rate_hz)) / H.rate_hz +
        pulse_duration_s(in.pulse) / 2;
    return finish_drive_signals(std::move(d.drive), H.rate_hz, delay, drive_options(in, drive));
}

} // namespace

std::vector<InverseFilterDesign> inverse_filter_designs(const CalibrationInput &in, const Plates &plates,
                                                        const ProgressFn &progress, bool shared)
{
    std::vector<std::vector<std::size_t>> sets;
    std::vector<std::string> names;
    for (std::size_t f = 0; f < in.foci.points.size(); f++) {
        sets.push_back({f});
        names.push_back("focus " + std::to_string(in.foci.points[f].id));
    }
    return scene_designs(in, plates, sets, names, shared, progress);
}

std::vector<DriveSignals> inverse_filter_signals(const CalibrationInput &in, const Plates &plates,
                                                 const ProgressFn &progress)
{
    std::vector<InverseFilterDesign> designs = inverse_filter_designs(in, plates, progress);
    std::vector<DriveSignals> out(designs.size());
    std::string failure;
#pragma omp parallel for schedule(dynamic, 1)
    for (std::size_t f = 0; f < designs.size(); f++) {
        try {
            out[f] = scene_signals(in, *plates.front(), std::move(designs[f]), f);
        } catch (const std::exception &e) {
#pragma omp critical(inverse_filter_failure)
            if (failure.empty())
                failure = "focus " + std::to_string(in.foci.points[f].id) + ": " + e.what();
        }
    }
    if (!failure.empty())
        throw std::runtime_error(failure);
    return out;
}

DriveSignals joint_inverse_filter_signals(const CalibrationInput &in, const TransferMatrix &H,
                                          const std::vector<std::size_t> &set)
{
    std::string ids;
    for (std::size_t f : set)
        ids += (ids.empty() ? "" : "+") + std::to_string(in.foci.points.at(f).id);
    InverseFilterDesign design = scene_designs(in, Plates{&H}, {set}, {"foci " + ids}, true, {}).front();
    try {
        DriveSignals d = scene_signals(in, H, std::move(design), joint_drive);
        if (in.effects.exciter && in.effects.exciter->precompensate) // as the table's drives
            precompensate_for_exciter(d, *in.effects.exciter, drive_options(in, joint_drive));
        return d;
    } catch (const std::exception &e) {
        throw std::runtime_error("foci " + ids + ": " + e.what());
    }
}

InverseFilterOptions scene_inverse_filter_options(const CalibrationInput &in)
{
    InverseFilterOptions o;
    o.regularization = in.calibration.regularization;
    o.band_edge_hz = pulse_max_frequency_hz(in.pulse);
    return o;
}

} // namespace calib::pipeline
