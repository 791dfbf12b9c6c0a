#include "study/design_case.h"

#include "io/format.h"
#include "model/resources.h"
#include "pipeline/calibrate.h"
#include "scene/calibration_input.h"
#include "scene/scene.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <stdexcept>

namespace calib::study {

namespace {

using Clock = std::chrono::steady_clock;

const char *edge_word(engine::EdgeKind k)
{
    switch (k) {
    case engine::EdgeKind::clamped:
        return "clamped";
    case engine::EdgeKind::simply_supported:
        return "simply_supported";
    case engine::EdgeKind::free:
        return "free";
    }
    return "?";
}

std::string edges_text(const engine::Edges &e)
{
    if (e.left == e.right && e.left == e.bottom && e.left == e.top)
        return edge_word(e.left);
    return std::string(edge_word(e.left)) + "/" + edge_word(e.right) + "/" + edge_word(e.bottom) + "/" +
           edge_word(e.top);
}

// Drive energy of one focus's signals at full scale (N^2 s): the normalized
// samples times the exciter force at full scale, squared, over the rate.
double drive_energy(const pipeline::DriveSignals &d, double force_full_scale_n)
{
    double sum = 0;
    for (double v : d.normalized)
        sum += v * v;
    return sum * force_full_scale_n * force_full_scale_n / d.rate_hz;
}

void read_inputs(const scene::Scene &s, CaseResult &r)
{
    r.material = s.plate.material.name;
    r.thickness_m = s.plate.thickness_m;
    r.edges = edges_text(s.plate.edges);
    if (s.exciters) {
        r.exciters = s.exciters->count;
        r.criterion = s.exciters->criterion == pipeline::PlacementCriterion::contrast ? "contrast" : "distance_variety";
        r.seed = s.exciters->seed;
    }
    if (s.pulse) {
        r.pulse_centre_hz = s.pulse->centre_hz;
        r.pulse_cycles = s.pulse->cycles;
    }
}

std::string one_line(std::string s)
{
    std::replace(s.begin(), s.end(), '\n', ' ');
    std::replace(s.begin(), s.end(), '\r', ' ');
    return s;
}

// Every digit: a number reads back exactly.
constexpr const char *exact = "%.17g";

} // namespace

CaseResult run_case(const Sweep &sweep, const Case &c, int rank)
{
    CaseResult r;
    r.index = c.index;
    r.id = c.id;
    r.rank = rank;
    const auto t0 = Clock::now();
    // Messages name the base scene and the case, never a temporary file.
    const std::string where = sweep.base_path + " (case " + std::to_string(c.index) + ")";
    try {
        const scene::Scene s = scene::parse_scene(c.scene_text, where);
        read_inputs(s, r);
        model::reset_peak_rss();
        const scene::PlateSetup setup = scene::build_plate(s);
        const pipeline::CalibrationInput in = scene::calibration_input(s, setup, c.scene_text);
        pipeline::check_feasible(in);
        const pipeline::CalibrationResult res = pipeline::calibrate(in);
        const pipeline::Verification &v = res.verification;
        r.foci = static_cast<unsigned>(v.foci.size());
        r.worst_contrast_db = INFINITY;
        r.min_peak_m = INFINITY;
        r.min_peak_per_sqrt_energy = INFINITY;
        for (size_t f = 0; f < v.foci.size(); f++) {
            const pipeline::FocusMetrics &m = v.foci[f];
            // One focus has no other foci: then its margin over the rest of
            // the plate at the focus instant is the contrast (as the accuracy study).
            const double contrast = v.foci.size() > 1 ? m.other_foci_contrast_db : m.field_contrast_db;
            r.worst_contrast_db = std::min(r.worst_contrast_db, contrast);
            r.max_spot_m = std::max(r.max_spot_m, m.spot_diameter_m);
            r.max_lead_time_s = std::max(r.max_lead_time_s, m.lead_time_s);
            r.foci_meeting_criterion += m.passes(); // the verdict (data/verdict.h)
            const double peak = res.full_scale_peak_m.at(f);
            r.min_peak_m = std::min(r.min_peak_m, peak);
            const double e = drive_energy(res.signals.at(f), in.exciters.force_full_scale_n);
            r.min_peak_per_sqrt_energy = std::min(r.min_peak_per_sqrt_energy, peak / std::sqrt(e));
        }
        r.simulation_s = res.times.simulation_s;
        r.search_s = res.times.search_s;
        r.verification_s = res.times.verification_s;
        r.ran = true;
    } catch (const std::exception &e) {
        r.ran = false;
        r.note = one_line(e.what());
    }
    r.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
    r.peak_rss_mb = model::peak_rss_mb();
    return r;
}

std::string case_file_name(const Case &c) { return c.id + ".case"; }

std::string encode_case(const CaseResult &r)
{
    std::ostringstream o;
    o << "format=haptic-design-case 1\n"
      << "index=" << r.index << "\n"
      << "id=" << r.id << "\n"
      << "material=" << r.material << "\n"
      << "thickness_m=" << io::fmt(exact, r.thickness_m) << "\n"
      << "edges=" << r.edges << "\n"
      << "exciters=" << r.exciters << "\n"
      << "criterion=" << r.criterion << "\n"
      << "seed=" << r.seed << "\n"
      << "pulse_centre_hz=" << io::fmt(exact, r.pulse_centre_hz) << "\n"
      << "pulse_cycles=" << io::fmt(exact, r.pulse_cycles) << "\n"
      << "ran=" << (r.ran ? 1 : 0) << "\n"
      << "note=" << one_line(r.note) << "\n"
      << "foci=" << r.foci << "\n"
      << "foci_meeting_criterion=" << r.foci_meeting_criterion << "\n"
      << "worst_contrast_db=" << io::fmt(exact, r.worst_contrast_db) << "\n"
      << "min_peak_m=" << io::fmt(exact, r.min_peak_m) << "\n"
      << "min_peak_per_sqrt_energy=" << io::fmt(exact, r.min_peak_per_sqrt_energy) << "\n"
      << "max_spot_m=" << io::fmt(exact, r.max_spot_m) << "\n"
      << "max_lead_time_s=" << io::fmt(exact, r.max_lead_time_s) << "\n"
      << "wall_s=" << io::fmt(exact, r.wall_s) << "\n"
      << "simulation_s=" << io::fmt(exact, r.simulation_s) << "\n"
      << "search_s=" << io::fmt(exact, r.search_s) << "\n"
      << "verification_s=" << io::fmt(exact, r.verification_s) << "\n"
      << "peak_rss_mb=" << io::fmt(exact, r.peak_rss_mb) << "\n"
      << "rank=" << r.rank << "\n"
      << "end=1\n";
    return o.str();
}

CaseResult decode_case(std::string_view text, const std::string &file)
{
    std::map<std::string, std::string> kv;
    std::istringstream in{std::string(text)};
    std::string line;
    while (std::getline(in, line)) {
        const size_t eq = line.find('=');
        if (eq == std::string::npos)
            throw std::runtime_error(file + ": not a case record (a line without '=')");
        kv[line.substr(0, eq)] = line.substr(eq + 1);
    }
    if (kv["format"] != "haptic-design-case 1" || kv["end"] != "1")
        throw std::runtime_error(file + ": not a whole case record");
    auto get = [&](const char *k) -> const std::string & {
        auto it = kv.find(k);
        if (it == kv.end())
            throw std::runtime_error(file + ": " + k + ": missing");
        return it->second;
    };
    auto d = [&](const char *k) {
        const std::string &s = get(k);
        char *end = nullptr;
        const double v = std::strtod(s.c_str(), &end);
        if (s.empty() || *end != '\0')
            throw std::runtime_error(file + ": " + k + ": not a number");
        return v;
    };
    auto u = [&](const char *k) {
        const std::string &s = get(k);
        char *end = nullptr;
        const unsigned long long v = std::strtoull(s.c_str(), &end, 10);
        if (s.empty() || *end != '\0')
            throw std::runtime_error(file + ": " + k + ": not an integer");
        return v;
    };
    CaseResult r;
    r.index = u("index");
    r.id = get("id");
    r.material = get("material");
    r.thickness_m = d("thickness_m");
    r.edges = get("edges");
    r.exciters = static_cast<unsigned>(u("exciters"));
    r.criterion = get("criterion");
    r.seed = u("seed");
    r.pulse_centre_hz = d("pulse_centre_hz");
    r.pulse_cycles = d("pulse_cycles");
    r.ran = u("ran") != 0;
    r.note = get("note");
    r.foci = static_cast<unsigned>(u("foci"));
    r.foci_meeting_criterion = static_cast<unsigned>(u("foci_meeting_criterion"));
    r.worst_contrast_db = d("worst_contrast_db");
    r.min_peak_m = d("min_peak_m");
    r.min_peak_per_sqrt_energy = d("min_peak_per_sqrt_energy");
    r.max_spot_m = d("max_spot_m");
    r.max_lead_time_s = d("max_lead_time_s");
    r.wall_s = d("wall_s");
    r.simulation_s = d("simulation_s");
    r.search_s = d("search_s");
    r.verification_s = d("verification_s");
    r.peak_rss_mb = d("peak_rss_mb");
    r.rank = static_cast<int>(u("rank"));
    return r;
}

} // namespace calib::study
