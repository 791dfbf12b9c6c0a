#include "pipeline/bench/bench_model.h"

#include "engine/simulation.h"
#include "pipeline/robustness/tolerance.h"
#include "pipeline/signal/real_fft.h"
#include "pipeline/transfer/transfer.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <future>
#include <numbers>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

const char *sensor_quantity_name(SensorQuantity q)
{
    switch (q) {
    case SensorQuantity::displacement:
        return "displacement";
    case SensorQuantity::velocity:
        return "velocity";
    case SensorQuantity::acceleration:
        return "acceleration";
    }
    return "?";
}

struct BenchModel::Traces {
    double rate_hz = 0;
    std::size_t samples = 0, points = 0;
    std::vector<float> data; // [sensor][node][sample]
    const float *at(std::size_t sensor, std::size_t node) const
    {
        return data.data() + (sensor * points + node) * samples;
    }
};

namespace {

// Catmull-Rom weights for the points -1, 0, 1, 2 at fraction t in [0, 1).
inline void catmull_rom(double t, double w[4])
{
    const double t2 = t * t, t3 = t2 * t;
    w[0] = 0.5 * (-t3 + 2 * t2 - t);
    w[1] = 0.5 * (3 * t3 - 5 * t2 + 2);
    w[2] = 0.5 * (-3 * t3 + 4 * t2 + t);
    w[3] = 0.5 * (t3 - t2);
}

} // namespace

BenchModel::BenchModel(const CalibrationInput &in, BenchSetup setup) : in_(in), setup_(std::move(setup))
{
    const engine::Grid &g = in_.plate->grid();
    if (setup_.sensors.empty() || setup_.exciters.empty())
        throw std::invalid_argument("bench: no sensor or no exciter");
    for (std::size_t s = 0; s < setup_.sensors.size(); s++) {
        const Point p = setup_.sensors[s].at;
        if (!(p.x_m > 0 && p.x_m < g.length_x_m() && p.y_m > 0 && p.y_m < g.length_y_m()))
            throw std::invalid_argument("bench: sensor " + std::to_string(s) + " is off the plate");
    }
    if (!(setup_.f_lo_hz > 0 && setup_.f_hi_hz > setup_.f_lo_hz && setup_.window_s > 0))
        throw std::invalid_argument("bench: the fit band and window must be positive");
    // The model's responses are double-precision simulations: the fit
    // differentiates them numerically.
    in_.simulation.precision = engine::Precision::f64;
    nominal_eta_ = in_.plate->params().loss.active() ? loss_factor(*in_.plate, in_.pulse.centre_hz) : 0.0;

    const double f_top = 1.3 * setup_.f_hi_hz; // where the band's upper taper ends
    rate_hz_ = std::ceil(4 * f_top);
    window_ = static_cast<std::size_t>(std::ceil(setup_.window_s * rate_hz_));
    const double tail_s = std::max(0.25 * setup_.window_s, 3.0 / setup_.f_lo_hz);
    total_ = window_ + static_cast<std::size_t>(std::ceil(tail_s * rate_hz_));

    engine::Simulation probe(in_.plate, single_core_options(in_));
    const double k = probe.time_step_s();
    const auto decimation =
        std::max<std::size_t>(1, static_cast<std::size_t>(std::floor(1.0 / (k * 16 * setup_.f_hi_hz))));
    sim_rate_hz_ = 1.0 / (double(decimation) * k);
    if (sim_rate_hz_ < 8 * setup_.f_hi_hz)
        throw std::invalid_argument("bench: the fit band's top (" + std::to_string(int(setup_.f_hi_hz)) +
                                    " Hz) is beyond what the scene's time step resolves");
    sim_samples_ = static_cast<std::size_t>(std::ceil(double(total_) / rate_hz_ * setup_.speed_max * sim_rate_hz_)) + 4;

    // The node patches around each exciter: the radius, and one node more on
    // each side for the bicubic interpolation.
    for (const Point &p : setup_.exciters) {
        Patch pa;
        const double r = setup_.radius_m;
        const int i_lo = std::max(0, int(std::floor((p.x_m - r) / g.h)) - 1);
        const int i_hi = std::min(g.nx, int(std::ceil((p.x_m + r) / g.h)) + 1);
        const int j_lo = std::max(0, int(std::floor((p.y_m - r) / g.h)) - 1);
        const int j_hi = std::min(g.ny, int(std::ceil((p.y_m + r) / g.h)) + 1);
        if (i_lo >= i_hi || j_lo >= j_hi)
            throw std::invalid_argument("bench: an exciter is off the plate");
        pa.i0 = i_lo, pa.j0 = j_lo, pa.ni = i_hi - i_lo + 1, pa.nj = j_hi - j_lo + 1;
        pa.first = nodes_.size();
        for (int j = j_lo; j <= j_hi; j++)
            for (int i = i_lo; i <= i_hi; i++)
                nodes_.push_back({i * g.h, j * g.h});
        patches_.push_back(pa);
    }
}

BenchParams BenchModel::nominal() const
{
    BenchParams p;
    p.speed_ratio = 1;
    p.loss_factor = nominal_eta_;
    p.exciters = setup_.exciters;
    p.gains.assign(setup_.exciters.size(), 1.0);
    p.sensor_gains.assign(setup_.sensors.size(), 1.0);
    return p;
}

std::size_t BenchModel::simulations() const
{
    std::lock_guard<std::mutex> lock(mutex_);
    return simulations_;
}

std::shared_ptr<const BenchModel::Traces> BenchModel::traces_at(double eta) const
{
    // One simulation set per loss value, one set at a time (each runs its
    // sensors in parallel); a caller of a value being simulated waits for it.
    auto cached = [&]() -> std::shared_ptr<const Traces> {
        std::lock_guard<std::mutex> lock(mutex_);
        auto it = cache_.find(eta);
        if (it == cache_.end())
            return nullptr;
        it->second.used = ++uses_;
        return it->second.traces;
    };
    if (auto hit = cached())
        return hit;
    std::lock_guard<std::mutex> one_at_a_time(simulating_);
    if (auto hit = cached())
        return hit;
    {
        CalibrationInput pin = in_;
        if (nominal_eta_ > 0 && eta != nominal_eta_)
            pin = perturbed_input(in_, loss_case(in_, eta, "fit"));
        engine::Simulation probe(pin.plate, single_core_options(pin));
        TransferOptions o;
        o.decimation = std::max<std::size_t>(
            1, static_cast<std::size_t>(std::llround(1.0 / (probe.time_step_s() * sim_rate_hz_))));
        const double rate = 1.0 / (double(o.decimation) * probe.time_step_s());
        o.samples = static_cast<std::size_t>(std::ceil(double(sim_samples_) * rate / sim_rate_hz_)) + 4;
        o.lattice_stride = 0;
        // The force's band: flat over the fit band on every plate the model
        // takes (a speed ratio alpha moves a frequency f to alpha f), stopped
        // (-80 dB) below half the fit rate there: response() reads the node
        // responses at the fit rate, and a content above half of it would
        // alias into the band (an acceleration weighs it by omega^2).
        o.pass_hz = 1.3 * setup_.f_hi_hz / setup_.speed_min;
        o.stop_hz = 0.5 * rate_hz_ / setup_.speed_max;
        std::vector<Point> sources;
        for (const BenchSensor &s : setup_.sensors)
            sources.push_back(s.at);
        const TransferMatrix H = simulate_transfer(pin, sources, nodes_, o);
        auto t = std::make_shared<Traces>();
        t->rate_hz = H.rate_hz;
        t->samples = H.samples;
        t->points = H.point_count();
        t->data = H.data;
        std::lock_guard<std::mutex> lock(mutex_);
        // A small cache, the least recently used value out first: a fit's
        // derivative asks for a value and its two neighbours, pair after pair.
        while (cache_.size() >= 8) {
            auto victim = cache_.begin();
            for (auto c = cache_.begin(); c != cache_.end(); ++c)
                if (c->second.used < victim->second.used)
                    victim = c;
            cache_.erase(victim);
        }
        cache_[eta] = {t, ++uses_};
        simulations_ += sources.size();
        return t;
    }
}

std::vector<double> BenchModel::band(const std::vector<double> &x, int derivative) const
{
    const std::size_t n = next_pow2(2 * total_);
    static thread_local std::unique_ptr<RealFft> fft;
    if (!fft || fft->size() != n)
        fft = std::make_unique<RealFft>(n);
    fft->forward_padded(x.data(), std::min(x.size(), total_));
    const double lo0 = 0.5 * setup_.f_lo_hz, lo1 = setup_.f_lo_hz, hi0 = setup_.f_hi_hz, hi1 = 1.3 * setup_.f_hi_hz;
    std::complex<double> *spec = fft->spectrum();
    for (std::size_t b = 0; b < fft->bins(); b++) {
        const double f = double(b) * rate_hz_ / double(n);
        double w = 0;
        if (f >= lo1 && f <= hi0)
            w = 1;
        else if (f > lo0 && f < lo1)
            w = 0.5 * (1 - std::cos(std::numbers::pi * (f - lo0) / (lo1 - lo0)));
        else if (f > hi0 && f < hi1)
            w = 0.5 * (1 + std::cos(std::numbers::pi * (f - hi0) / (hi1 - hi0)));
        std::complex<double> d = w / double(n);
        const std::complex<double> jw(0, 2 * std::numbers::pi * f);
        for (int q = 0; q < derivative; q++)
            d *= jw;
        spec[b] *= d;
    }
    fft->inverse();
    return std::vector<double>(fft->real(), fft->real() + window_);
}

void BenchModel::response(const BenchParams &p, std::size_t s, std::size_t e, double *out) const
{
    const std::shared_ptr<const Traces> tr = traces_at(p.loss_factor);
    const engine::Grid &g = in_.plate->grid();
    const Patch &pa = patches_[e];
    const double alpha = std::clamp(p.speed_ratio, setup_.speed_min, setup_.speed_max);
    // Space: the bicubic interpolation of the patch's node responses at the
    // exciter's position (indices held inside the patch).
    const double fx = p.exciters[e].x_m / g.h, fy = p.exciters[e].y_m / g.h;
    const int ci = int(std::floor(fx)), cj = int(std::floor(fy));
    double wx[4], wy[4];
    catmull_rom(fx - ci, wx);
    catmull_rom(fy - cj, wy);
    const std::size_t needed =
        std::min(tr->samples, static_cast<std::size_t>(std::ceil(double(total_) / rate_hz_ * alpha * tr->rate_hz)) + 3);
    std::vector<double> h(needed, 0.0);
    // A node beyond the plate's edge is the edge's ghost node: the mirror of
    // the node inside, with the sign of its condition (clamped +, simply
    // supported -; a free edge extrapolates linearly).
    auto add_node = [&](int i, int j, double w) {
        const float *r = tr->at(s, pa.first + std::size_t(j - pa.j0) * std::size_t(pa.ni) + std::size_t(i - pa.i0));
        for (std::size_t n = 0; n < needed; n++)
            h[n] += w * double(r[n]);
    };
    const engine::Edges &edges = in_.plate->params().edges;
    auto axis = [](int i, int lo, int hi, int n, engine::EdgeKind low, engine::EdgeKind high,
                   std::vector<std::pair<int, double>> &out) {
        out.clear();
        auto edge = [&](int inside_step, int edge_node, engine::EdgeKind kind) {
            if (kind == engine::EdgeKind::free) { // 2 u_edge - u_inside
                out.push_back({edge_node, 2.0});
                out.push_back({edge_node + inside_step, -1.0});
            } else {
                out.push_back({edge_node + inside_step, kind == engine::EdgeKind::clamped ? 1.0 : -1.0});
            }
        };
        if (i < 0)
            edge(1, 0, low);
        else if (i > n)
            edge(-1, n, high);
        else
            out.push_back({i, 1.0});
        for (auto &[k, w] : out)
            k = std::clamp(k, lo, hi); // inside the patch (the radius keeps the exciter's cell in it)
    };
    std::vector<std::pair<int, double>> xs, ys;
    for (int b = 0; b < 4; b++) {
        axis(cj - 1 + b, pa.j0, pa.j0 + pa.nj - 1, g.ny, edges.bottom, edges.top, ys);
        for (int a = 0; a < 4; a++) {
            axis(ci - 1 + a, pa.i0, pa.i0 + pa.ni - 1, g.nx, edges.left, edges.right, xs);
            for (const auto &[j, wj] : ys)
                for (const auto &[i, wi] : xs)
                    add_node(i, j, wx[a] * wy[b] * wi * wj);
        }
    }
    // Time: H_alpha(t) = H(alpha t) / alpha, at the fit rate (Catmull-Rom; the
    // node responses are stored at 16 times the band's top or more).
    const double scale = setup_.force_full_scale_n * p.gains[e] * p.sensor_gains[s] / alpha;
    std::vector<double> y(total_, 0.0);
    auto at = [&](std::ptrdiff_t n) { return n >= 0 && std::size_t(n) < needed ? h[std::size_t(n)] : 0.0; };
    for (std::size_t m = 0; m < total_; m++) {
        const double u = alpha * double(m) / rate_hz_ * tr->rate_hz;
        const auto n = static_cast<std::ptrdiff_t>(std::floor(u));
        double w[4];
        catmull_rom(u - double(n), w);
        y[m] = scale * (w[0] * at(n - 1) + w[1] * at(n) + w[2] * at(n + 1) + w[3] * at(n + 2));
    }
    const std::vector<double> f = band(y, int(setup_.sensors[s].quantity));
    std::copy(f.begin(), f.end(), out);
}

} // namespace calib::pipeline
