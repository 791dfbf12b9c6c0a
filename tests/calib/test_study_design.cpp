// Design sweeps (calib/study/): sweep files, case enumeration and ids, the
// per-case record and the report's choices, without running calibrations
// (tests/calib/study_design.sh runs them, under mpirun too).
#include "scene/scene.h"
#include "study/design_case.h"
#include "study/design_report.h"
#include "study/sweep.h"

#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <string>

using namespace calib;
using namespace calib::study;

namespace {

// The sweep "lives" next to the shipped scenes so that base = "..." resolves.
const std::string sweep_file = std::string(HAPTIC_SOURCE_DIR) + "/scenes/unit-test-sweep.toml";

Sweep sweep_of(const std::string &body) { return parse_sweep("base = \"test-study-small.toml\"\n" + body, sweep_file); }

// The message of the SweepError a sweep body raises ("" when none).
std::string refusal(const std::string &body)
{
    try {
        (void)sweep_of(body);
    } catch (const SweepError &e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST(StudySweep, CartesianProductInFileOrderLastAxisFastest)
{
    const Sweep s = sweep_of("[axes]\nexciter_count = [4, 6]\nedges = [\"clamped\", \"free\", \"simply_supported\"]\n");
    ASSERT_EQ(s.axes.size(), 2u);
    EXPECT_EQ(s.axes[0].name, "exciter_count"); // file order, not toml++'s key order
    const auto cases = enumerate_cases(s);
    ASSERT_EQ(cases.size(), 6u);
    const char *edges[] = {"clamped", "free", "simply_supported"};
    for (size_t i = 0; i < 6; i++) {
        EXPECT_EQ(cases[i].index, i);
        EXPECT_EQ(cases[i].values[0], i < 3 ? "4" : "6");
        EXPECT_EQ(cases[i].values[1], edges[i % 3]);
        const scene::Scene sc = scene::parse_scene(cases[i].scene_text, "case.toml");
        EXPECT_EQ(sc.exciters->count, i < 3 ? 4u : 6u);
        EXPECT_EQ(sc.plate.edges.left, sc.plate.edges.top);
        EXPECT_EQ(sc.pulse->centre_hz, 1200); // untouched base keys stay
    }
}

TEST(StudySweep, CaseIdsAreStableAndDependOnTheCaseOnly)
{
    const auto a = enumerate_cases(sweep_of("[axes]\nexciter_count = [4, 6]\nseed = [1, 2]\n"));
    const auto b = enumerate_cases(sweep_of("[axes]\nexciter_count = [4, 6]\nseed = [1, 2]\n"));
    const auto swapped = enumerate_cases(sweep_of("[axes]\nseed = [1, 2]\nexciter_count = [4, 6]\n"));
    std::set<std::string> ids, ids_swapped;
    for (size_t i = 0; i < a.size(); i++) {
        EXPECT_EQ(a[i].id, b[i].id);
        EXPECT_EQ(a[i].id.size(), 16u);
        ids.insert(a[i].id);
        ids_swapped.insert(swapped[i].id);
    }
    EXPECT_EQ(ids.size(), 4u);   // distinct cases, distinct ids
    EXPECT_EQ(ids, ids_swapped); // the same case in another order keeps its id (and its result file)
    // Case (4, 1) of the first order is case (1, 4) of the second: index 0 both times.
    EXPECT_EQ(a[1].id, swapped[2].id); // exciters 4, seed 2
}

TEST(StudySweep, RangesIncludeTheirEnd)
{
    const Sweep s = sweep_of("[axes]\nthickness_m = {from = 0.002, to = 0.004, step = 0.001}\n"
                             "exciter_count = {from = 4, to = 12, step = 4}\nseed = {from = 1, to = 3}\n");
    ASSERT_EQ(s.axes[0].values.size(), 3u);
    EXPECT_DOUBLE_EQ(*s.axes[0].values.get(2)->value<double>(), 0.004);
    ASSERT_EQ(s.axes[1].values.size(), 3u);
    EXPECT_EQ(*s.axes[1].values.get(2)->value<int64_t>(), 12);
    EXPECT_EQ(s.axes[2].values.size(), 3u); // integer axes step by 1 unless told
    EXPECT_EQ(s.case_count(), 27u);
}

TEST(StudySweep, SetAppliesToEveryCaseAndAxesOverrideIt)
{
    const Sweep s = sweep_of("[set.plate.loss]\nt60_s = [0.2, 0.05]\n[set.exciters]\ncount = 5\nseed = 9\n"
                             "[axes]\nexciter_count = [4, 6]\n");
    for (const Case &c : enumerate_cases(s)) {
        const scene::Scene sc = scene::parse_scene(c.scene_text, "case.toml");
        EXPECT_EQ(sc.plate.loss->t60_2_s, 0.05);
        EXPECT_EQ(sc.plate.loss->f2_hz, 1200); // the merge keeps the base's other loss key
        EXPECT_EQ(sc.exciters->seed, 9u);
        EXPECT_NE(sc.exciters->count, 5u);
    }
}

TEST(StudySweep, RefusedInOneLineNamingFileAndKey)
{
    struct Bad {
        const char *body, *key, *what;
    } bad[] = {
        {"[axes]\ncolour = [\"red\"]\n", "axes.colour", "unknown axis"},
        {"[axes]\nthickness_m = {from = 0.004, to = 0.002, step = 0.001}\n", "axes.thickness_m.to", "empty range"},
        {"[axes]\nexciter_count = []\n", "axes.exciter_count", "empty list"},
        {"[axes]\nexciter_count = [4, 6.5]\n", "axes.exciter_count", "must be an integer"},
        {"[axes]\nthickness_m = [\"thin\"]\n", "axes.thickness_m", "must be a number"},
        {"[axes]\nmaterial = {from = 1, to = 2}\n", "axes.material", "needs numbers"},
        {"[axes]\nseed = {from = 1, to = 3, step = 0}\n", "axes.seed.step", "must be > 0"},
        {"[axes]\nexciter_count = {from = 4, to = 8, step = 0.5}\n", "axes.exciter_count.step", "integer"},
        {"[axes]\nthickness_m = 0.002\n", "axes.thickness_m", "list of values or a range"},
        {"colour = 1\n", "colour", "unknown key"},
        {"[constraints]\nmax_exciters = 0\n", "constraints.max_exciters", ">= 1"},
    };
    for (const Bad &b : bad) {
        const std::string m = refusal(b.body);
        SCOPED_TRACE(b.body);
        EXPECT_EQ(m.rfind(sweep_file + ": " + b.key + ": ", 0), 0u) << m;
        EXPECT_NE(m.find(b.what), std::string::npos) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
    try {
        (void)parse_sweep("name = \"x\"\n", sweep_file);
        FAIL() << "a sweep without a base scene";
    } catch (const SweepError &e) {
        EXPECT_NE(std::string(e.what()).find(": base: missing"), std::string::npos) << e.what();
    }
    try {
        (void)parse_sweep("base = \"no-such-scene.toml\"\n", sweep_file);
        FAIL() << "a missing base scene";
    } catch (const SweepError &e) {
        EXPECT_NE(std::string(e.what()).find("no-such-scene.toml"), std::string::npos) << e.what();
    }
    EXPECT_NE(refusal("[axes]\nseed = {from = 1, to = 1000000000}\n").find("at most"), std::string::npos);
}

TEST(StudyCase, RecordRoundTripsExactly)
{
    CaseResult r;
    r.index = 7;
    r.id = "0123456789abcdef";
    r.material = "acrylic";
    r.edges = "clamped/free/clamped/free";
    r.criterion = "contrast";
    r.thickness_m = 0.1 + 0.2; // not a short decimal
    r.pulse_centre_hz = 300;
    r.pulse_cycles = 2.5;
    r.exciters = 8;
    r.seed = 18446744073709551615ull;
    r.ran = true;
    r.note = "a note, with a comma\nand a newline";
    r.foci = 9;
    r.foci_meeting_criterion = 4;
    r.worst_contrast_db = 1.0 / 3.0;
    r.min_peak_m = 7.123456789012345e-6;
    r.min_peak_per_sqrt_energy = 2.5e-4;
    r.max_spot_m = 0.081;
    r.max_lead_time_s = 0.0571;
    r.wall_s = 12.5;
    r.peak_rss_mb = 512.25;
    r.rank = 3;
    const CaseResult d = decode_case(encode_case(r), "x.case");
    EXPECT_EQ(encode_case(d), encode_case(r));
    EXPECT_EQ(std::memcmp(&d.thickness_m, &r.thickness_m, sizeof(double)), 0);
    EXPECT_EQ(std::memcmp(&d.worst_contrast_db, &r.worst_contrast_db, sizeof(double)), 0);
    EXPECT_EQ(d.seed, r.seed);
    EXPECT_EQ(d.note, "a note, with a comma and a newline"); // one line in the record
    // A record cut short (a writer killed mid-way would leave no file at all,
    // but a foreign or damaged file must not pass for a result).
    const std::string whole = encode_case(r);
    EXPECT_THROW(decode_case(whole.substr(0, whole.size() / 2), "x.case"), std::runtime_error);
}

TEST(StudyReport, CsvHasNoCostColumnsAndSummaryPicksByConstraint)
{
    auto make = [](size_t i, unsigned exciters, double contrast, unsigned meeting, double wall) {
        CaseResult r;
        r.index = i;
        r.id = "id" + std::to_string(i);
        r.material = "acrylic";
        r.edges = "clamped";
        r.criterion = "contrast";
        r.thickness_m = 0.002;
        r.exciters = exciters;
        r.ran = true;
        r.foci = 9;
        r.foci_meeting_criterion = meeting;
        r.worst_contrast_db = contrast;
        r.max_spot_m = 0.08;
        r.max_lead_time_s = 0.06;
        r.wall_s = wall;
        return r;
    };
    std::vector<CaseResult> cases = {make(0, 4, 3.0, 5, 1), make(1, 6, 7.0, 9, 2), make(2, 8, 9.0, 9, 3),
                                     make(3, 10, 8.0, 9, 4)};
    CaseResult refused = make(4, 12, 0, 0, 5);
    refused.ran = false;
    refused.note = "exciters.count: no room";
    cases.push_back(refused);
    const std::string csv = design_csv(cases);
    auto slow = cases;
    for (CaseResult &r : slow) {
        r.wall_s *= 10;
        r.peak_rss_mb += 100;
        r.rank += 1;
    }
    EXPECT_EQ(design_csv(slow), csv); // cost and rank stay out of the compared CSV
    EXPECT_NE(timing_csv(slow), timing_csv(cases));
    EXPECT_NE(csv.find("4,id4,acrylic,0.002,clamped,12,contrast,0,0,0,refused,,,,,,,,exciters.count: no room\n"),
              std::string::npos)
        << csv;

    Sweep s = sweep_of("");
    s.constraints.min_contrast_db = 7.5;
    const std::string md = design_summary(s, cases);
    auto row = [&](const std::string &question) {
        const size_t at = md.find("| " + question);
        return at == std::string::npos ? std::string() : md.substr(at, md.find('\n', at) - at);
    };
    EXPECT_NE(row("Highest worst-focus contrast").find("| 2 |"), std::string::npos) << md;
    // Case 0 has the fewest exciters but not every focus meets the criterion.
    EXPECT_NE(row("Fewest exciters with every focus meeting the criterion").find("| 1 |"), std::string::npos) << md;
    EXPECT_NE(row("Within the constraints (contrast >= 7.5 dB): fewest exciters").find("| 2 |"), std::string::npos)
        << md;
}
