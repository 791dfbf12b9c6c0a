// The latency study end to end on the small inverse-filter plate (2 x 2
// foci, 36 mm apart at least, all 6 pairs and 4 triples valid): every case's
// counts against its own sets, the joint designs only in the inverse
// filter's cases, the files it writes and what they hold.
#include "study/latency.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

using namespace calib;

namespace {

std::string read(const std::string &path)
{
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

std::size_t lines(const std::string &text)
{
    std::size_t n = 0;
    for (char c : text)
        n += c == '\n';
    return n;
}

} // namespace

TEST(LatencyStudy, JointDesignsBesideTheSuperpositionInTheInverseFilterCases)
{
    study::LatencyOptions o;
    o.lead_times_s = {0.006};
    o.triples = o.joint = true;
    const std::string scene = std::string(HAPTIC_TEST_SCENES) + "/inverse.toml";
    const study::LatencyResult r = study::run_latency_study(scene, o);
    ASSERT_EQ(r.rows.size(), 4u); // both methods at the scene's window and at 6 ms
    ASSERT_EQ(r.focus_ids.size(), 4u);
    std::size_t joint_rows = 0;
    for (const study::LatencyRow &x : r.rows) {
        ASSERT_TRUE(x.error.empty()) << x.error;
        EXPECT_EQ(x.pairs, 6u);
        EXPECT_EQ(x.triples, 4u);
        ASSERT_EQ(x.sets.size(), 10u);
        std::size_t pf = 0, tf = 0;
        const bool inverse = x.method == pipeline::DriveMethod::inverse_filter;
        for (const pipeline::MultiTouchCase &c : x.sets) {
            (c.foci.size() == 2 ? pf : tf) += !c.superposed.ok;
            EXPECT_EQ(c.has_joint, inverse);
        }
        EXPECT_EQ(pf, x.pairs_failing);
        EXPECT_EQ(tf, x.triples_failing);
        joint_rows += inverse;
    }
    EXPECT_EQ(joint_rows, 2u);

    const auto dir = std::filesystem::temp_directory_path() / ("latency-study-" + std::to_string(::getpid()));
    const std::string md = study::write_latency_report(r, dir.string());
    // Every set of both inverse-filter cases, superposed and joint, and a header.
    EXPECT_EQ(lines(read((dir / "multitouch.csv").string())), 1u + 2 * 10 * 2);
    EXPECT_EQ(lines(read((dir / "latency.csv").string())), 1u + 4);
    EXPECT_TRUE(std::filesystem::file_size(dir / "multitouch.svg") > 0);
    EXPECT_NE(md.find("Several fingers"), std::string::npos);
    EXPECT_EQ(md, read((dir / "latency.md").string()));
    std::filesystem::remove_all(dir);

    // Without joint designs: no multitouch files, no table.
    study::LatencyResult plain = r;
    for (study::LatencyRow &x : plain.rows)
        for (pipeline::MultiTouchCase &c : x.sets)
            c.has_joint = false;
    const auto dir2 = std::filesystem::temp_directory_path() / ("latency-study-plain-" + std::to_string(::getpid()));
    (void)study::write_latency_report(r, dir2.string()); // an earlier run with joint designs, same directory
    ASSERT_TRUE(std::filesystem::exists(dir2 / "multitouch.csv"));
    const std::string md2 = study::write_latency_report(plain, dir2.string());
    EXPECT_FALSE(std::filesystem::exists(dir2 / "multitouch.csv"));
    EXPECT_FALSE(std::filesystem::exists(dir2 / "multitouch.svg"));
    EXPECT_EQ(md2.find("Several fingers"), std::string::npos);
    std::filesystem::remove_all(dir2);
}
