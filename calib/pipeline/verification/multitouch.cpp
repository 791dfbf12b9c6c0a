#include "pipeline/verification/multitouch.h"

#include "pipeline/data/input.h"
#include "pipeline/design/inverse_filter.h"
#include "pipeline/signal/peaks.h"
#include "pipeline/transfer/playback.h"
#include "pipeline/verification/verification.h"

#include <algorithm>
#include <cmath>

namespace calib::pipeline {

namespace {

constexpr std::size_t peak_block = 64;  // firmware/src/program.h HD_PEAK_BLOCK

}  // namespace

double mixer_gain(const std::vector<const std::vector<int16_t> *> &s, unsigned C)
{
    const std::size_t K = s.size();
    std::size_t n = 0;
    for (const auto *x : s)
        n = std::max(n, x->size());
    // Gram entries over the common length (shorter signals end in silence).
    double e_ref = 0, e_sum = 0;
    for (std::size_t i = 0; i < K; i++)
        for (std::size_t j = 0; j < K; j++) {
            const std::size_t m = std::min(s[i]->size(), s[j]->size());
            double g = 0;
            for (std::size_t k = 0; k < m; k++)
                g += double((*s[i])[k]) * double((*s[j])[k]);
            e_sum += g;
            if (i == j)
                e_ref += g;
        }
    e_ref /= double(K);
    const double g_energy = e_sum > 0 ? std::sqrt(e_ref / e_sum) : 0.0;
    double bound = 0;
    const std::size_t frames = n / C;
    for (std::size_t b = 0; b * peak_block < frames; b++)
        for (unsigned c = 0; c < C; c++) {
            double sum = 0;
            for (const auto *x : s) {
                int peak = 0;
                for (std::size_t f = b * peak_block; f < std::min(frames, (b + 1) * peak_block); f++)
                    if (f * C + c < x->size())
                        peak = std::max(peak, std::abs(int((*x)[f * C + c])));
                sum += peak;
            }
            bound = std::max(bound, sum);
        }
    const double g_peak = bound > 0 ? 32767.0 / bound : 1.0;
    return std::min({g_energy, g_peak, 1.0});
}

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
    std::vector<std::size_t> lattice;  // active-area lattice points
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
        if (cap_at_amplitude && gain > 0 && loudest > in.pulse.amplitude_m) {  // the field is at `gain` already
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
        const double g = mixer_gain(s, unsigned(C));
        std::vector<float> mix(frames * C, 0.0f);
        for (const auto *x : s)
            for (std::size_t i = 0; i < x->size(); i++)
                mix[i] += static_cast<float>(g * double((*x)[i]) / 32767.0);
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

}  // namespace calib::pipeline
