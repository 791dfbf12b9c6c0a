#include "engine/mindlin/mindlin_engine.h"

#include "engine/non_finite.h"
#include "io/format.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace calib::engine::mindlin {

namespace {

// Larger systems step on an OpenMP team (below it the fork costs more than the rows).
constexpr Eigen::Index parallel_min_unknowns = 200000;

} // namespace

MindlinEngine::MindlinEngine(std::shared_ptr<const MindlinOperator> op, double time_step_s)
    : op_(std::move(op)), k_(time_step_s)
{
    if (!op_)
        throw std::invalid_argument("MindlinEngine: no operator");
    const double bound = op_->max_time_step();
    if (!(k_ > 0) || k_ >= bound)
        throw std::invalid_argument("thick_plate: time step " + std::to_string(k_) +
                                    " s is not below the Mindlin stability bound " + std::to_string(bound) + " s");
    const Eigen::VectorXd scale = (k_ * k_) * op_->mass().cwiseInverse();
    update_ = scale.asDiagonal() * op_->stiffness();
    update_.makeCompressed();
    const Eigen::Index n = Eigen::Index(op_->unknown_count());
    prev_ = Eigen::VectorXd::Zero(n);
    cur_ = Eigen::VectorXd::Zero(n);
    next_ = Eigen::VectorXd::Zero(n);
}

MindlinEngine::Tap MindlinEngine::tap_at(double x_m, double y_m, bool scale_by_mass) const
{
    const Grid &g = op_->grid();
    if (!(x_m >= 0 && x_m <= g.length_x_m() && y_m >= 0 && y_m <= g.length_y_m()))
        throw std::invalid_argument("thick_plate: point (" + std::to_string(x_m) + ", " + std::to_string(y_m) +
                                    ") m is off the plate");
    const double fx = x_m / g.h, fy = y_m / g.h;
    const int i = std::min(int(fx), g.nx - 1), j = std::min(int(fy), g.ny - 1);
    const double ax = fx - i, ay = fy - j;
    Tap t;
    const double wts[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
    const int di[4] = {0, 1, 0, 1}, dj[4] = {0, 0, 1, 1};
    for (int c = 0; c < 4; ++c) {
        const std::ptrdiff_t u = op_->w_index(i + di[c], j + dj[c]);
        if (u < 0 || wts[c] == 0)
            continue;
        t.index.push_back(Eigen::Index(u));
        t.weight.push_back(scale_by_mass ? wts[c] * k_ * k_ / op_->mass()[u] : wts[c]);
    }
    return t;
}

std::size_t MindlinEngine::add_source(double x_m, double y_m)
{
    sources_.push_back(tap_at(x_m, y_m, true));
    return sources_.size() - 1;
}

std::size_t MindlinEngine::add_receiver(double x_m, double y_m)
{
    receivers_.push_back(tap_at(x_m, y_m, false));
    return receivers_.size() - 1;
}

double MindlinEngine::receiver_value(std::size_t r) const
{
    const Tap &t = receivers_[r];
    double v = 0;
    for (std::size_t n = 0; n < t.index.size(); ++n)
        v += t.weight[n] * cur_[t.index[n]];
    return v;
}

void MindlinEngine::step()
{
    // Fused CSR rows: q+ = 2 q - q- - (k^2 M^-1 K) q. Written out rather than
    // Eigen's product, whose OpenMP split of a few thousand rows costs more
    // than the rows (measured 40x slower on a loaded 2-core machine).
    const Eigen::Index n = update_.rows();
    const int *outer = update_.outerIndexPtr();
    const int *inner = update_.innerIndexPtr();
    const double *value = update_.valuePtr();
    const double *c = cur_.data(), *p = prev_.data();
    double *out = next_.data();
#pragma omp parallel for schedule(static) if (n > parallel_min_unknowns)
    for (Eigen::Index r = 0; r < n; ++r) {
        double acc = 0;
        for (int e = outer[r]; e < outer[r + 1]; ++e)
            acc += value[e] * c[inner[e]];
        out[r] = 2 * c[r] - p[r] - acc;
    }
    for (const Tap &s : sources_)
        for (std::size_t n = 0; n < s.index.size(); ++n)
            next_[s.index[n]] += s.weight[n] * s.force;
    // The extensions: next_ = q+ (without their forces), cur_ = q, prev_ = q-.
    for (auto &ext : extensions_)
        ext->after_update(*this);
    prev_.swap(cur_);
    cur_.swap(next_);
    ++steps_;
}

double MindlinEngine::energy() const
{
    const Eigen::VectorXd v = (cur_ - prev_) / k_;
    return 0.5 * v.dot(op_->mass().cwiseProduct(v)) + 0.5 * cur_.dot(op_->stiffness() * prev_);
}

void MindlinEngine::set_state(const Eigen::VectorXd &current, const Eigen::VectorXd &previous)
{
    if (current.size() != cur_.size() || previous.size() != prev_.size())
        throw std::invalid_argument("MindlinEngine::set_state: size does not match the operator");
    cur_ = current;
    prev_ = previous;
}

bool MindlinEngine::threaded() const { return Eigen::Index(op_->unknown_count()) > parallel_min_unknowns; }

PointTaps MindlinEngine::couple(double x_m, double y_m, const char *effect) const
{
    const Tap t = tap_at(x_m, y_m, false);
    PointTaps p;
    for (std::size_t n = 0; n < t.index.size() && p.count < p.index.size(); ++n, ++p.count) {
        p.index[p.count] = std::ptrdiff_t(t.index[n]);
        p.weight[p.count] = t.weight[n];
        p.gain[p.count] = t.weight[n] * k_ * k_ / op_->mass()[t.index[n]];
        p.g += t.weight[n] * p.gain[p.count];
    }
    if (p.count == 0)
        throw std::invalid_argument(std::string(effect) + ": the point lies on held nodes only");
    return p;
}

PointLevels MindlinEngine::read(const PointTaps &point) const
{
    PointLevels w;
    for (std::size_t n = 0; n < point.count; ++n) {
        w.next += point.weight[n] * next_[point.index[n]];
        w.now += point.weight[n] * cur_[point.index[n]];
        w.prev += point.weight[n] * prev_[point.index[n]];
    }
    return w;
}

void MindlinEngine::apply(const PointTaps &point, double force_n)
{
    for (std::size_t n = 0; n < point.count; ++n)
        next_[point.index[n]] += point.gain[n] * force_n;
}

double MindlinEngine::w_at(int i, int j) const
{
    const std::ptrdiff_t u = op_->w_index(i, j);
    return u >= 0 ? cur_[u] : 0.0;
}

std::vector<double> MindlinEngine::displacement() const
{
    const Grid &g = op_->grid();
    std::vector<double> w(std::size_t(g.nx + 1) * std::size_t(g.ny + 1), 0.0);
    for (int j = 0; j <= g.ny; ++j)
        for (int i = 0; i <= g.nx; ++i)
            if (const std::ptrdiff_t u = op_->w_index(i, j); u >= 0)
                w[g.node(i, j)] = cur_[u];
    return w;
}

std::string MindlinEngine::non_finite_report() const
{
    const Eigen::VectorXd &q = cur_;
    if (!any_non_finite(q.data(), long(q.size())))
        return {};
    const Grid &g = op_->grid();
    std::size_t count = 0;
    Eigen::Index first = -1;
    for (Eigen::Index u = 0; u < q.size(); ++u)
        if (!std::isfinite(q[u]) && count++ == 0)
            first = u;
    using io::fmt;
    std::string where;
    for (int j = 0; j <= g.ny && where.empty(); ++j)
        for (int i = 0; i <= g.nx && where.empty(); ++i) {
            const std::ptrdiff_t u = op_->w_index(i, j);
            if (u >= 0 && !std::isfinite(q[u]))
                where = "first w at node (i, j) = (" + std::to_string(i) + ", " + std::to_string(j) + "), (x, y) = (" +
                        fmt("%.6g", i * g.h) + ", " + fmt("%.6g", j * g.h) + ") m";
        }
    if (where.empty())
        where =
            "first at rotation unknown " + std::to_string(first - Eigen::Index(op_->w_count())) + " (w still finite)";
    return "non-finite value (" + fmt("%g", q[first]) + ") of the thick plate at step " + std::to_string(steps_ - 1) +
           " (t = " + fmt("%.6g", double(steps_) * k_) + " s), " + where + "; " + std::to_string(count) +
           " non-finite unknowns of " + std::to_string(q.size());
}

} // namespace calib::engine::mindlin
