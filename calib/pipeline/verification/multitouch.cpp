#include "pipeline/verification/multitouch.h"

#include "pipeline/data/input.h"
#include "pipeline/design/inverse_filter.h"
#include "pipeline/signal/peaks.h"
#include "pipeline/transfer/playback.h"
#include "pipeline/verification/verification.h"

#include <haptic_mix.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace calib::pipeline {

namespace {

struct GramView {
    const std::vector<double> *g;
    std::size_t k;
};

double gram_at(const void *ctx, uint32_t i, uint32_t j)
{
    const auto *v = static_cast<const GramView *>(ctx);
    return (*v->g)[i * v->k + j];
}

} // namespace

DeviceMix device_mix(const std::vector<const std::vector<int16_t> *> &s, unsigned C, double level, double gain_limit)
{
    const std::size_t K = s.size();
    std::size_t n = 0;
    for (const auto *x : s)
        n = std::max(n, x->size());
    // The Gram matrix over the common length, exact integer sums rounded once
    // (as a table's own: the device reads it from the table).
    std::vector<double> gram(K * K);
    for (std::size_t i = 0; i < K; i++)
        for (std::size_t j = 0; j < K; j++) {
            const std::size_t m = std::min(s[i]->size(), s[j]->size());
            int64_t dot = 0;
            for (std::size_t k = 0; k < m; k++)
                dot += int64_t((*s[i])[k]) * int64_t((*s[j])[k]);
            gram[i * K + j] = double(dot);
        }
    // The peak envelopes, each over its own frames, silence after.
    const uint32_t frames = uint32_t(n / C), blocks = haptic_mix_blocks(frames);
    std::vector<std::vector<uint16_t>> env(K, std::vector<uint16_t>(std::size_t(blocks) * C, 0));
    std::vector<const uint16_t *> envs(K);
    for (std::size_t k = 0; k < K; k++) {
        haptic_mix_block_peaks(s[k]->data(), uint32_t(s[k]->size() / C), C, env[k].data());
        envs[k] = env[k].data();
    }
    const GramView view{&gram, K};
    haptic_mix_gain g;
    haptic_mix_gain_of(gram_at, &view, uint32_t(K), haptic_mix_peak_bound(envs.data(), uint32_t(K), blocks, C), level,
                       gain_limit, &g);
    // The device's render: the exact sum of the counts times the Q30 gain.
    std::vector<int64_t> acc(n, 0);
    for (const auto *x : s)
        for (std::size_t i = 0; i < x->size(); i++)
            acc[i] += (*x)[i];
    for (auto &a : acc)
        a *= g.gain_q30;
    DeviceMix out;
    out.gain = g.gain;
    out.samples.resize(n);
    haptic_mix_to_s16(acc.data(), out.samples.data(), uint32_t(n));
    return out;
}

double mixer_gain(const std::vector<const std::vector<int16_t> *> &s, unsigned C) { return device_mix(s, C).gain; }

double SetVerdict::contrast_db() const
{
    return 20 * std::log10(std::max(min_focus_peak_m, 1e-300) / std::max(max_elsewhere_m, 1e-300));
}

MultiTouchReport verify_multitouch(const CalibrationInput &in, const TransferMatrix &H,
                                   const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                                   const MultiTouchOptions &options)
{
    const std::size_t K = in.foci.points.size(), C = H.channels, L = H.lattice.size();
    const double lambda_half = judged_lambda_half_m(in);
    std::vector<std::vector<std::size_t>> sets;
    auto apart = [&](std::size_t a, std::size_t b) {
        return dist(in.foci.points[a].at, in.foci.points[b].at) >= lambda_half;
    };
    for (std::size_t a = 0; a < K; a++)
        for (std::size_t b = a + 1; b < K; b++) {
            if (!apart(a, b))
                continue;
            sets.push_back({a, b});
            for (std::size_t c = b + 1; options.triples && c < K; c++)
                if (apart(a, c) && apart(b, c))
                    sets.push_back({a, b, c});
        }
    MultiTouchReport rep;
    if (sets.empty())
        return rep;

    // The joint designs first: the playback below serves the longest drive.
    if (options.joint && in.robust)
        throw std::invalid_argument("multi-touch: joint designs are of the nominal plate, the table is robust "
                                    "(calibration.robust)");
    std::vector<std::vector<int16_t>> joint(options.joint ? sets.size() : 0);
    for (std::size_t i = 0; i < joint.size(); i++)
        joint[i] = joint_inverse_filter_signals(in, H, sets[i]).samples;
    std::size_t frames = 0;
    for (const auto &s : signals)
        frames = std::max(frames, s.size() / C);
    for (const auto &s : joint)
        frames = std::max(frames, s.size() / C);
    const std::size_t drive = static_cast<std::size_t>(std::ceil(double(frames) * H.rate_hz / rate_hz)) + 1;
    std::vector<std::size_t> served;
    for (std::size_t f = 0; f < K; f++)
        served.push_back(H.exact_begin() + f);
    const Rect &area = in.active.area;
    std::vector<std::size_t> lattice; // active-area lattice points
    for (std::size_t n = 0; n < L; n++) {
        const Point p = H.lattice.at(n);
        if (p.x_m >= area.x0_m && p.x_m <= area.x1_m && p.y_m >= area.y0_m && p.y_m <= area.y1_m) {
            served.push_back(n);
            lattice.push_back(n);
        }
    }
    Playback pb(H, served, drive,
                drive + static_cast<std::size_t>(std::ceil(in.calibration.verify_tail_s * H.rate_hz)));

    // The field of a mix ([frame][channel], full scale 1, `gain` applied),
    // judged for the touched foci of `set`; with cap_at_amplitude the gain is
    // first lowered, if need be, until no touched focus exceeds the scene's
    // amplitude (the field is linear in it).
    auto judge = [&](const std::vector<std::size_t> &set, const std::vector<float> &mix, double gain,
                     bool cap_at_amplitude) {
        auto w = pb.field(drive_forces(in, H, mix, unsigned(C), rate_hz));
        SetVerdict v;
        v.gain = gain;
        for (float x : mix)
            v.energy += double(x) * double(x) * 32767.0 * 32767.0;
        // The touched foci's peaks, once (the cap scales them with the field).
        std::vector<double> focal;
        for (std::size_t f : set)
            focal.push_back(refined_peak(w[f]).value);
        double loudest = *std::max_element(focal.begin(), focal.end());
        if (cap_at_amplitude && gain > 0 && loudest > in.pulse.amplitude_m) { // the field is at `gain` already
            v.gain = gain * in.pulse.amplitude_m / loudest;
            const double k = v.gain / gain;
            v.energy *= k * k;
            loudest *= k;
            for (double &p : focal)
                p *= k;
            for (auto &x : w)
                for (float &y : x)
                    y = static_cast<float>(y * k);
        }
        v.max_focus_peak_m = loudest;
        auto far_from_all = [&](Point p) {
            for (std::size_t f : set)
                if (dist(p, in.foci.points[f].at) <= lambda_half)
                    return false;
            return true;
        };
        v.min_focus_peak_m = *std::min_element(focal.begin(), focal.end());
        for (std::size_t g = 0; g < K; g++)
            if (far_from_all(in.foci.points[g].at)) {
                const double x = refined_peak(w[g]).value;
                if (x > v.max_elsewhere_m) {
                    v.max_elsewhere_m = x;
                    v.elsewhere_at = in.foci.points[g].at;
                }
            }
        for (std::size_t i = 0; i < lattice.size(); i++) {
            const Point p = H.lattice.at(lattice[i]);
            if (!far_from_all(p))
                continue;
            const std::vector<float> &x = w[K + i];
            if (sample_peak(x.data(), x.size()) < 0.8 * v.max_elsewhere_m)
                continue;
            const double y = refined_peak(x).value;
            if (y > v.max_elsewhere_m) {
                v.max_elsewhere_m = y;
                v.elsewhere_at = p;
            }
        }
        const double thr = in.calibration.threshold_m;
        v.ok = v.min_focus_peak_m >= thr && v.max_elsewhere_m < thr;
        v.margin_m = std::min(v.min_focus_peak_m - thr, thr - v.max_elsewhere_m);
        return v;
    };
    auto energy = [](const std::vector<int16_t> &x) {
        double e = 0;
        for (int16_t v : x)
            e += double(v) * double(v);
        return e;
    };

    double worst_margin = INFINITY;
    for (std::size_t k = 0; k < sets.size(); k++) {
        MultiTouchCase mc;
        mc.foci = sets[k];
        std::vector<const std::vector<int16_t> *> s;
        for (std::size_t f : mc.foci)
            s.push_back(&signals[f]);
        // The field of what the device plays for these fingers.
        const DeviceMix played = device_mix(s, unsigned(C));
        const double g = played.gain;
        std::vector<float> mix(frames * C, 0.0f);
        for (std::size_t i = 0; i < played.samples.size(); i++)
            mix[i] = static_cast<float>(double(played.samples[i]) / 32767.0);
        mc.superposed = judge(mc.foci, mix, g, false);
        if (options.joint) {
            const std::vector<int16_t> &x = joint[k];
            const double e = energy(x);
            const double gj = std::min(1.0, e > 0 ? std::sqrt(mc.superposed.energy / e) : 0.0);
            std::fill(mix.begin(), mix.end(), 0.0f);
            for (std::size_t i = 0; i < x.size(); i++)
                mix[i] = static_cast<float>(gj * double(x[i]) / 32767.0);
            mc.joint = judge(mc.foci, mix, gj, true);
            mc.has_joint = true;
        }
        rep.failing += !mc.superposed.ok;
        if (mc.superposed.margin_m < worst_margin) {
            worst_margin = mc.superposed.margin_m;
            rep.worst = rep.cases.size();
        }
        rep.cases.push_back(std::move(mc));
    }
    return rep;
}

} // namespace calib::pipeline
