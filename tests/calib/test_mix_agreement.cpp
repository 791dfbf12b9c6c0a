// One mixing law, two programs: calibgen's multi-touch verification judges
// the samples hapticd plays. Three foci of a table (the fixture's signals,
// with full-scale extremes, so the peak bound binds) rendered by hapticd's
// own player, and calibgen's device_mix of the same stored signals: equal
// sample for sample; and one focus alone plays as stored.
#include "pipeline/verification/multitouch.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <unistd.h>
#include <vector>

#include "fw_render.h"
extern "C" {
#include "table_fixture.h"
}

using namespace calib;

namespace {

struct FixtureTable {
    table_fixture fx;
    std::string path;
    FixtureTable(uint16_t channels, uint32_t foci, uint32_t samples, uint32_t seed)
    {
        table_fixture_init(&fx, channels, foci, samples, seed);
        char tmpl[] = "/tmp/mix-agreement-XXXXXX";
        const int fd = mkstemp(tmpl);
        EXPECT_GE(fd, 0);
        close(fd);
        path = tmpl;
        haptic_table_error err;
        EXPECT_EQ(haptic_table_write(path.c_str(), &fx.spec, &err), 0) << err.message;
    }
    ~FixtureTable()
    {
        std::remove(path.c_str());
        table_fixture_free(&fx);
    }
    std::vector<int16_t> signal(uint32_t f) const
    {
        const std::size_t n = std::size_t(fx.spec.samples_per_signal) * fx.spec.channel_count;
        return {fx.samples + f * n, fx.samples + (f + 1) * n};
    }
};

} // namespace

TEST(MixAgreement, ThreeFociSampleForSample)
{
    const uint16_t C = 8;
    const uint32_t N = 1000;
    FixtureTable t(C, 5, N, 17);
    const uint32_t ids[] = {t.fx.ids[0], t.fx.ids[2], t.fx.ids[4]};
    std::vector<int16_t> device(std::size_t(N) * C);
    ASSERT_EQ(fw_render_s16(t.path.c_str(), ids, 3, device.data(), N), 0);
    const auto a = t.signal(0), b = t.signal(2), c = t.signal(4);
    const pipeline::DeviceMix judged = pipeline::device_mix({&a, &b, &c}, C);
    ASSERT_EQ(judged.samples.size(), device.size());
    std::size_t differ = 0;
    for (std::size_t i = 0; i < device.size(); i++)
        differ += judged.samples[i] != device[i];
    EXPECT_EQ(differ, 0u) << "of " << device.size() << " samples";
    // The peak bound binds for these signals (full-scale extremes in each):
    // the gain is below the energy law's, and nothing saturates.
    EXPECT_LT(judged.gain, 1 / std::sqrt(3.0));
    EXPECT_GT(judged.gain, 0.0);
}

TEST(MixAgreement, OneFocusPlaysAsStored)
{
    const uint16_t C = 4;
    const uint32_t N = 300;
    FixtureTable t(C, 2, N, 3);
    std::vector<int16_t> device(std::size_t(N) * C);
    ASSERT_EQ(fw_render_s16(t.path.c_str(), &t.fx.ids[1], 1, device.data(), N), 0);
    const auto s = t.signal(1);
    const pipeline::DeviceMix judged = pipeline::device_mix({&s}, C);
    EXPECT_EQ(judged.gain, 1.0);
    EXPECT_EQ(judged.samples, s);
    EXPECT_EQ(device, s);
}
