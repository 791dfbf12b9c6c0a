#include "engine/effects/thick_plate.h"

#include "engine/spectrum.h"

#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

namespace calib::engine::effects {

namespace {

// Ghost sign of the normal rotation across an edge: a simply supported edge
// has no moment (symmetric ghost: the normal curvature vanishes), a clamped
// one no rotation (antisymmetric ghost).
double ghost_sign(EdgeKind e)
{
    return e == EdgeKind::clamped ? -1.0 : 1.0;
}

}  // namespace

MindlinOperator::MindlinOperator(const PlateParams &params, const Grid &grid, physics::MindlinShear shear)
    : params_(params), grid_(grid)
{
    const Edges &e = params.edges;
    for (EdgeKind k : {e.left, e.right, e.bottom, e.top})
        if (k == EdgeKind::free)
            throw std::invalid_argument("thick_plate: free edges are not implemented for the Mindlin plate");
    if (params.loss.active())
        throw std::invalid_argument("thick_plate: loss is not implemented for the Mindlin plate");
    if (grid.nx < 2 || grid.ny < 2 || !(grid.h > 0))
        throw std::invalid_argument("thick_plate: grid needs at least 2 x 2 intervals");
    const int nx = grid.nx, ny = grid.ny;
    const double h = grid.h, d = params.thickness_m;
    const physics::Material &m = params.material;
    const double D = m.bending_stiffness(d), nu = m.poisson;
    // From E and nu, as D is (and as physics::mindlin_phase_velocity does).
    const double G = m.youngs_pa / (2 * (1 + nu));
    shear_ = physics::mindlin_shear_factor(m, shear) * G * d;

    // Numbering.
    std::ptrdiff_t n = 0;
    w_of_node_.assign(grid.node_count(), -1);
    for (int j = 1; j < ny; ++j)
        for (int i = 1; i < nx; ++i) {
            w_of_node_[grid.node(i, j)] = n++;
            w_node_.push_back(grid.node(i, j));
        }
    const std::ptrdiff_t nw = n;
    psix_of_.assign(std::size_t(nx) * std::size_t(ny + 1), -1);  // (i, j), i < nx
    for (int j = 1; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
            psix_of_[std::size_t(j) * std::size_t(nx) + std::size_t(i)] = n++;
    const std::ptrdiff_t npx = n - nw;
    psiy_of_.assign(std::size_t(nx + 1) * std::size_t(ny), -1);  // (i, j), j < ny
    for (int j = 0; j < ny; ++j)
        for (int i = 1; i < nx; ++i)
            psiy_of_[std::size_t(j) * std::size_t(nx + 1) + std::size_t(i)] = n++;
    const std::ptrdiff_t npy = n - nw - npx;

    const double rho = m.density_kg_m3;
    mass_.resize(n);
    mass_.head(nw).setConstant(rho * d * h * h);
    mass_.segment(nw, npx).setConstant(rho * d * d * d / 12 * h * h);
    mass_.tail(npy).setConstant(rho * d * d * d / 12 * h * h);

    // K = h^2 sum_r c_r b_r b_r^T over the strain rows b_r.
    std::vector<Eigen::Triplet<double>> trip;
    using Row = std::map<std::ptrdiff_t, double>;
    auto add_row = [&](const Row &row, double c) {
        if (c == 0)
            return;
        for (auto [a, va] : row)
            for (auto [b, vb] : row)
                if (va != 0 && vb != 0)
                    trip.emplace_back(Eigen::Index(a), Eigen::Index(b), h * h * c * va * vb);
    };
    auto put = [](Row &row, std::ptrdiff_t idx, double v) {
        if (idx >= 0)
            row[idx] += v;
    };
    // d psi_x / dx at node (i, j), ghosts across the left/right edges.
    auto kxx = [&](int i, int j, double s) {
        Row r;
        const int il = i - 1, ir = i;
        if (il < 0)
            put(r, psi_x_index(0, j), -s * ghost_sign(e.left) / h);
        else
            put(r, psi_x_index(il, j), -s / h);
        if (ir > nx - 1)
            put(r, psi_x_index(nx - 1, j), s * ghost_sign(e.right) / h);
        else
            put(r, psi_x_index(ir, j), s / h);
        return r;
    };
    auto kyy = [&](int i, int j, double s) {
        Row r;
        const int jb = j - 1, jt = j;
        if (jb < 0)
            put(r, psi_y_index(i, 0), -s * ghost_sign(e.bottom) / h);
        else
            put(r, psi_y_index(i, jb), -s / h);
        if (jt > ny - 1)
            put(r, psi_y_index(i, ny - 1), s * ghost_sign(e.top) / h);
        else
            put(r, psi_y_index(i, jt), s / h);
        return r;
    };
    auto merge = [](Row a, const Row &b) {
        for (auto [k, v] : b)
            a[k] += v;
        return a;
    };
    for (int j = 0; j <= ny; ++j)
        for (int i = 0; i <= nx; ++i) {
            const double wn = (i == 0 || i == nx ? 0.5 : 1.0) * (j == 0 || j == ny ? 0.5 : 1.0);
            // q = kxx^2 + kyy^2 + 2 nu kxx kyy = (1+nu)/2 (kxx+kyy)^2 + (1-nu)/2 (kxx-kyy)^2
            add_row(merge(kxx(i, j, 1), kyy(i, j, 1)), D * wn * (1 + nu) / 2);
            add_row(merge(kxx(i, j, 1), kyy(i, j, -1)), D * wn * (1 - nu) / 2);
        }
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
            Row r;
            put(r, psi_x_index(i, j + 1), 1 / h);
            put(r, psi_x_index(i, j), -1 / h);
            put(r, psi_y_index(i + 1, j), 1 / h);
            put(r, psi_y_index(i, j), -1 / h);
            add_row(r, D * (1 - nu) / 2);
        }
    for (int j = 0; j <= ny; ++j)
        for (int i = 0; i < nx; ++i) {
            Row r;
            put(r, w_index(i + 1, j), 1 / h);
            put(r, w_index(i, j), -1 / h);
            put(r, psi_x_index(i, j), 1);
            add_row(r, shear_ * (j == 0 || j == ny ? 0.5 : 1.0));
        }
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i <= nx; ++i) {
            Row r;
            put(r, w_index(i, j + 1), 1 / h);
            put(r, w_index(i, j), -1 / h);
            put(r, psi_y_index(i, j), 1);
            add_row(r, shear_ * (i == 0 || i == nx ? 0.5 : 1.0));
        }
    stiffness_.resize(n, n);
    stiffness_.setFromTriplets(trip.begin(), trip.end());
    stiffness_.prune(0.0);
}

std::ptrdiff_t MindlinOperator::w_index(int i, int j) const
{
    if (i < 0 || i > grid_.nx || j < 0 || j > grid_.ny)
        return -1;
    return w_of_node_[grid_.node(i, j)];
}

std::ptrdiff_t MindlinOperator::psi_x_index(int i, int j) const
{
    if (i < 0 || i >= grid_.nx || j < 0 || j > grid_.ny)
        return -1;
    return psix_of_[std::size_t(j) * std::size_t(grid_.nx) + std::size_t(i)];
}

std::ptrdiff_t MindlinOperator::psi_y_index(int i, int j) const
{
    if (i < 0 || i > grid_.nx || j < 0 || j >= grid_.ny)
        return -1;
    return psiy_of_[std::size_t(j) * std::size_t(grid_.nx + 1) + std::size_t(i)];
}

double MindlinOperator::lambda_max() const
{
    if (lambda_ < 0)
        lambda_ = largest_generalized_eigenvalue(stiffness_, mass_);
    return lambda_;
}

double MindlinOperator::max_time_step() const
{
    return 2.0 / std::sqrt(lambda_max());
}

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
#pragma omp parallel for schedule(static) if (n > 200000)
    for (Eigen::Index r = 0; r < n; ++r) {
        double acc = 0;
        for (int e = outer[r]; e < outer[r + 1]; ++e)
            acc += value[e] * c[inner[e]];
        out[r] = 2 * c[r] - p[r] - acc;
    }
    for (const Tap &s : sources_)
        for (std::size_t n = 0; n < s.index.size(); ++n)
            next_[s.index[n]] += s.weight[n] * s.force;
    for (Finger &f : fingers_)
        apply_finger(f);
    prev_.swap(cur_);
    cur_.swap(next_);
    ++steps_;
}

std::size_t MindlinEngine::add_finger(const FingerSpec &spec)
{
    if (!(spec.mass_kg >= 0) || !(spec.stiffness_n_m >= 0) || !(spec.damping_n_s_m >= 0))
        throw std::invalid_argument("finger: mass, stiffness and damping must be >= 0");
    Finger f;
    f.spec = spec;
    f.phi = tap_at(spec.x_m, spec.y_m, false);
    if (f.phi.index.empty())
        throw std::invalid_argument("finger: the point lies on held nodes only");
    for (std::size_t n = 0; n < f.phi.index.size(); ++n) {
        f.gain.push_back(f.phi.weight[n] * k_ * k_ / op_->mass()[f.phi.index[n]]);
        f.g += f.phi.weight[n] * f.gain.back();
    }
    // Explicit spring: it raises lambda_max(M^-1 K) by at most s g / k^2 (as in finger.cpp).
    const double margin = 1.0 - k_ * k_ * op_->lambda_max() / 4.0;
    if (spec.stiffness_n_m * f.g / 4.0 >= margin)
        throw std::invalid_argument("finger: stiffness_n_m too high for the time step (needs s < " +
                                    std::to_string(4.0 * margin / f.g) + " N/m)");
    fingers_.push_back(std::move(f));
    return fingers_.size() - 1;
}

void MindlinEngine::apply_finger(Finger &f)
{
    // During step(): next_ = q+ (free of the finger), cur_ = q, prev_ = q-.
    double wp = 0, w = 0, wm = 0;
    for (std::size_t n = 0; n < f.phi.index.size(); ++n) {
        wp += f.phi.weight[n] * next_[f.phi.index[n]];
        w += f.phi.weight[n] * cur_[f.phi.index[n]];
        wm += f.phi.weight[n] * prev_[f.phi.index[n]];
    }
    const double m = f.spec.mass_kg, c = f.spec.damping_n_s_m, s = f.spec.stiffness_n_m, k = k_;
    const double alpha = m / (k * k) + c / (2 * k);
    const double beta = m * (2 * w - wm) / (k * k) + c * wm / (2 * k) - s * w;
    const double w_new = (wp + f.g * beta) / (1 + f.g * alpha);
    f.force = beta - alpha * w_new;
    for (std::size_t n = 0; n < f.phi.index.size(); ++n)
        next_[f.phi.index[n]] += f.gain[n] * f.force;
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

}  // namespace calib::engine::effects
