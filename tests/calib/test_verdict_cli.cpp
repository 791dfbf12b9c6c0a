// The verdict as a user meets it: `calibgen calibrate` and `calibgen verify`
// exit 3 when a focus fails it (after writing the table and the report), 0
// when every focus passes, and the terminal and metrics.json say which focus
// fails and why. Independent truths:
//  - Calibrate*: a scene with the regular exciter pattern (no placement search)
//    whose table is known to fail at the 10 um target (a ghost at 7.7 um, 2.3 dB
//    whole-area contrast) and, by linearity, to pass at 5.7 um (the ghost at
//    4.4 um, the focus at 5.7 um over the 5 um threshold);
//  - Verify*: a table built by hand through the library (verdict_ghost.h): the
//    same scene's drives scaled to pass, then a ghost added to one focus's drive
//    at a lattice point we chose, well after its focal instant; the scaled
//    table without the ghost must pass.
#include "pipeline/calibrate.h"
#include "pipeline/table_writer.h"

#include <haptic_table.h>

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "calibgen_run.h"
#include "verdict_ghost.h"

namespace fs = std::filesystem;
using namespace calib;

namespace {

using calibgen_run::Outcome;
using calibgen_run::read_text;

void write_text(const fs::path &p, const std::string &text)
{
    std::ofstream f(p, std::ios::binary);
    f << text;
}

// Just enough JSON for metrics.json: objects, arrays, strings, numbers, true, false, null.
struct Json {
    enum Kind { null, boolean, number, string, array, object } kind = null;
    bool b = false;
    double n = 0;
    std::string s;
    std::vector<Json> items;
    std::map<std::string, Json> fields;

    const Json &operator[](const std::string &key) const
    {
        static const Json missing;
        const auto it = fields.find(key);
        return it == fields.end() ? missing : it->second;
    }
    bool has(const std::string &key) const { return fields.count(key) != 0; }

    static Json parse(const std::string &text)
    {
        std::size_t at = 0;
        Json j = value(text, at);
        skip(text, at);
        if (at != text.size())
            throw std::runtime_error("json: trailing text at " + std::to_string(at));
        return j;
    }

  private:
    static void skip(const std::string &t, std::size_t &at)
    {
        while (at < t.size() && std::isspace(static_cast<unsigned char>(t[at])))
            at++;
    }
    static void expect(const std::string &t, std::size_t &at, char c)
    {
        skip(t, at);
        if (at >= t.size() || t[at] != c)
            throw std::runtime_error(std::string("json: expected '") + c + "' at " + std::to_string(at));
        at++;
    }
    static std::string str(const std::string &t, std::size_t &at)
    {
        expect(t, at, '"');
        std::string out;
        while (at < t.size() && t[at] != '"') {
            if (t[at] == '\\') {
                at++;
                const char e = t[at];
                out += e == 'n' ? '\n' : e == 't' ? '\t' : e; // \uXXXX does not occur in these files
            } else {
                out += t[at];
            }
            at++;
        }
        at++;
        return out;
    }
    static Json value(const std::string &t, std::size_t &at)
    {
        skip(t, at);
        Json j;
        if (at >= t.size())
            throw std::runtime_error("json: unexpected end");
        const char c = t[at];
        if (c == '{') {
            j.kind = object;
            at++;
            skip(t, at);
            if (t[at] == '}') {
                at++;
                return j;
            }
            for (;;) {
                const std::string key = str(t, at);
                expect(t, at, ':');
                j.fields[key] = value(t, at);
                skip(t, at);
                if (t[at++] == '}')
                    return j;
            }
        }
        if (c == '[') {
            j.kind = array;
            at++;
            skip(t, at);
            if (t[at] == ']') {
                at++;
                return j;
            }
            for (;;) {
                j.items.push_back(value(t, at));
                skip(t, at);
                if (t[at++] == ']')
                    return j;
            }
        }
        if (c == '"') {
            j.kind = string;
            j.s = str(t, at);
            return j;
        }
        for (const char *word : {"true", "false", "null"})
            if (t.compare(at, std::strlen(word), word) == 0) {
                at += std::strlen(word);
                j.kind = word[0] == 'n' ? null : boolean;
                j.b = word[0] == 't';
                return j;
            }
        j.kind = number;
        std::size_t used = 0;
        j.n = std::stod(t.substr(at, 40), &used);
        at += used;
        return j;
    }
};

class VerdictCli : public ::testing::Test {
  protected:
    void SetUp() override
    {
        const auto *info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() / ("haptic-verdict-" + std::to_string(::getpid()) + "-" + info->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    Outcome run(const std::string &args) const { return calibgen_run::run(dir_, args); }
    static std::string q(const fs::path &p) { return "\"" + p.string() + "\""; }

    fs::path dir_;
};

// The line of the terminal summary (focus  x_mm  y_mm ... verdict) of the focus `id`.
std::string focus_line(const std::string &err, uint32_t id)
{
    std::istringstream in(err);
    std::string line;
    const std::string head = std::to_string(id) + " ";
    while (std::getline(in, line))
        if (line.compare(0, head.size(), head) == 0 &&
            (line.find(" pass") != std::string::npos || line.find(" FAIL: ") != std::string::npos))
            return line;
    return "";
}

const Json *focus_json(const Json &metrics, uint32_t id)
{
    for (const Json &f : metrics["foci"].items)
        if (f["id"].n == id)
            return &f;
    return nullptr;
}

} // namespace

TEST_F(VerdictCli, CalibrateExits3OnAGhostAfterWritingTableAndReport)
{
    const fs::path scene = dir_ / "regular.toml", table = dir_ / "t.htab", report = dir_ / "report";
    write_text(scene, verdict_ghost::scene_text("10e-6"));
    const Outcome r = run("calibrate " + q(scene) + " -o " + q(table) + " --report " + q(report));
    EXPECT_EQ(r.exit_code, 3) << r.err;
    // The table and the report are written all the same.
    haptic_table t{};
    haptic_table_error e{};
    ASSERT_EQ(haptic_table_open(table.string().c_str(), &t, &e), 0) << e.message;
    EXPECT_EQ(t.focus_count, 2u);
    haptic_table_close(&t);
    ASSERT_TRUE(fs::exists(report / "index.html"));
    const Json m = Json::parse(read_text(report / "metrics.json"));
    ASSERT_TRUE(m.has("verdict")) << read_text(report / "metrics.json");
    EXPECT_FALSE(m["verdict"]["all_pass"].b);
    EXPECT_EQ(m["verdict"]["foci"].n, 2);
    EXPECT_LT(m["verdict"]["foci_passing"].n, 2);
    EXPECT_EQ(m["verdict"]["scope"].s, "whole area");
    bool ghost = false;
    for (const Json &f : m["foci"].items) {
        if (f["passes"].b)
            continue;
        EXPECT_TRUE(f["crosses_threshold"].b);
        EXPECT_NE(f["failure"].s, "");
        ghost |= !f["whole_area_below_threshold"].b && f["failure"].s.find("ghost") != std::string::npos;
        EXPECT_NE(r.err.find("FAIL: " + f["failure"].s), std::string::npos) << r.err;
    }
    EXPECT_TRUE(ghost) << read_text(report / "metrics.json");
    // The safe range (test_safe_range.cpp checks it against the verdict of the
    // scaled table): in metrics.json from the focus's own figures, the same on
    // its terminal line and in the report, as the table stores it. Each focus
    // fails on its ghost, so both ends lie below the stored level.
    ASSERT_EQ(haptic_table_open(table.string().c_str(), &t, &e), 0) << e.message;
    const double thr = m["threshold_m"].n;
    for (const Json &f : m["foci"].items) {
        SCOPED_TRACE("focus " + std::to_string(int(f["id"].n)));
        const Json &range = f["safe_range_db"];
        ASSERT_EQ(range.items.size(), 2u) << range.s;
        const double lo_db = range.items[0].n, hi_db = range.items[1].n;
        EXPECT_NEAR(lo_db, 20 * std::log10(thr / f["peak_m"].n), 1e-9);
        EXPECT_NEAR(hi_db, 20 * std::log10(thr / std::max(f["max_whole_area_m"].n, f["max_other_foci_m"].n)), 1e-9);
        EXPECT_LT(lo_db, hi_db);
        EXPECT_LT(hi_db, 0);
        char text[64];
        std::snprintf(text, sizeof text, " %+.1f .. %+.1f FAIL: ", lo_db, hi_db);
        EXPECT_NE(focus_line(r.err, uint32_t(f["id"].n)).find(text), std::string::npos) << r.err;
        const int32_t index = haptic_table_find_focus(&t, uint32_t(f["id"].n));
        ASSERT_GE(index, 0);
        haptic_gain_range stored{};
        ASSERT_EQ(haptic_table_gain_range(&t, uint32_t(index), &stored), 0);
        EXPECT_NEAR(20 * std::log10(stored.lo), lo_db, 1e-9);
        EXPECT_NEAR(20 * std::log10(stored.hi), hi_db, 1e-9);
    }
    haptic_table_close(&t);
    EXPECT_NE(read_text(report / "index.html").find("<th>safe range (dB re the stored level)</th>"), std::string::npos);
    EXPECT_NE(r.err.find("safe_range_dB verdict\n"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("verdict (whole area, all times): " + std::to_string(int(m["verdict"]["foci_passing"].n)) +
                         " of 2 foci pass: the table makes ghosts or misses the threshold (exit status 3)"),
              std::string::npos)
        << r.err;
}

TEST_F(VerdictCli, CalibrateExits0WhenEveryFocusPasses)
{
    // The same plate and exciters, stored at 5.7 um: every ghost below 5 um.
    const fs::path scene = dir_ / "regular-low.toml", table = dir_ / "t.htab", report = dir_ / "report";
    write_text(scene, verdict_ghost::scene_text("5.7e-6"));
    const Outcome r = run("calibrate " + q(scene) + " -o " + q(table) + " --report " + q(report));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(fs::exists(table));
    const Json m = Json::parse(read_text(report / "metrics.json"));
    EXPECT_TRUE(m["verdict"]["all_pass"].b);
    EXPECT_EQ(m["verdict"]["foci_passing"].n, 2);
    for (const Json &f : m["foci"].items) {
        EXPECT_TRUE(f["passes"].b);
        EXPECT_FALSE(f.has("failure"));
        EXPECT_NEAR(f["peak_m"].n, 5.7e-6, 0.05e-6); // the level is set for the target amplitude
        EXPECT_LT(f["max_whole_area_m"].n, 5e-6);
        // Passing at the stored level: the safe range holds 0 dB.
        const Json &range = f["safe_range_db"];
        ASSERT_EQ(range.items.size(), 2u) << range.s;
        EXPECT_LE(range.items[0].n, 0);
        EXPECT_TRUE(range.items[1].kind == Json::string ? range.items[1].s == "unbounded" : range.items[1].n > 0);
    }
    EXPECT_NE(r.err.find("verdict (whole area, all times): 2 of 2 foci pass\n"), std::string::npos) << r.err;
}

TEST_F(VerdictCli, VerifyExits3OnATableWithAHandMadeGhostAnd0Without)
{
    const verdict_ghost::Case g = verdict_ghost::build(verdict_ghost::scene_text());
    const double thr = g.in.calibration.threshold_m;
    const pipeline::FocusMetrics &lib = g.result.verification.foci[g.ghost_focus];
    ASSERT_FALSE(lib.passes()); // the library's verdict (test_verdict.cpp checks it in full)
    const fs::path scene = dir_ / "regular.toml";
    write_text(scene, verdict_ghost::scene_text());

    // The ghosted table.
    const fs::path table = dir_ / "ghost.htab", report = dir_ / "report";
    pipeline::write_table(table.string(), g.in, g.result);
    const Outcome r = run("verify " + q(scene) + " " + q(table) + " --report " + q(report));
    EXPECT_EQ(r.exit_code, 3) << r.err;
    const uint32_t id = g.in.foci.points[g.ghost_focus].id, other = g.in.foci.points[1 - g.ghost_focus].id;
    const std::string line = focus_line(r.err, id);
    EXPECT_NE(line.find("FAIL: ghost"), std::string::npos) << r.err;
    char where[64];
    std::snprintf(where, sizeof where, "at (%.1f, %.1f) mm", lib.whole_area_max_at.x_m * 1e3,
                  lib.whole_area_max_at.y_m * 1e3);
    EXPECT_NE(line.find(where), std::string::npos) << line;
    EXPECT_NE(focus_line(r.err, other).find(" pass"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("verdict (whole area, all times): 1 of 2 foci pass"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("verify: NOT met"), std::string::npos) << r.err;
    const Json m = Json::parse(read_text(report / "metrics.json"));
    EXPECT_FALSE(m["verdict"]["all_pass"].b);
    EXPECT_EQ(m["verdict"]["foci_passing"].n, 1);
    EXPECT_EQ(m["verdict"]["worst_focus_id"].n, id);
    const Json *f = focus_json(m, id);
    ASSERT_NE(f, nullptr);
    EXPECT_FALSE((*f)["passes"].b);
    EXPECT_FALSE((*f)["whole_area_below_threshold"].b);
    EXPECT_TRUE((*f)["crosses_threshold"].b);
    EXPECT_TRUE((*f)["others_below_threshold"].b);
    EXPECT_NE((*f)["failure"].s.find("ghost"), std::string::npos);
    EXPECT_NE((*f)["failure"].s.find(where), std::string::npos) << (*f)["failure"].s;
    EXPECT_EQ((*f)["failure"].s, lib.failure(thr));
    // Where the ghost is: within a lattice spacing or two of the point we chose.
    ASSERT_EQ((*f)["whole_area_max_xy_m"].items.size(), 2u);
    const pipeline::Point at{(*f)["whole_area_max_xy_m"].items[0].n, (*f)["whole_area_max_xy_m"].items[1].n};
    EXPECT_LE(pipeline::dist(at, g.ghost_at), 1.5 * g.H.lattice.spacing_m);
    const Json *o = focus_json(m, other);
    ASSERT_NE(o, nullptr);
    EXPECT_TRUE((*o)["passes"].b);

    // The same table without the ghost passes: exit 0.
    pipeline::CalibrationResult clean = g.result;
    for (std::size_t k = 0; k < clean.signals.size(); k++) {
        clean.signals[k].samples = g.clean[k];
        clean.signals[k].frames = g.clean[k].size() / g.H.channels;
    }
    clean.verification = g.clean_v;
    const fs::path clean_table = dir_ / "clean.htab", clean_report = dir_ / "clean-report";
    pipeline::write_table(clean_table.string(), g.in, clean);
    const Outcome c = run("verify " + q(scene) + " " + q(clean_table) + " --report " + q(clean_report));
    EXPECT_EQ(c.exit_code, 0) << c.err;
    EXPECT_NE(c.err.find("verdict (whole area, all times): 2 of 2 foci pass\n"), std::string::npos) << c.err;
    EXPECT_TRUE(Json::parse(read_text(clean_report / "metrics.json"))["verdict"]["all_pass"].b);
}
