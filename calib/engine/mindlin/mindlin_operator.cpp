#include "engine/mindlin/mindlin_operator.h"

#include "engine/spectrum.h"

#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

namespace calib::engine::mindlin {

namespace {

// Ghost sign of the normal rotation across an edge: a simply supported edge
// has no moment (symmetric ghost: the normal curvature vanishes), a clamped
// one no rotation (antisymmetric ghost).
double ghost_sign(EdgeKind e) { return e == EdgeKind::clamped ? -1.0 : 1.0; }

} // namespace

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
    psix_of_.assign(std::size_t(nx) * std::size_t(ny + 1), -1); // (i, j), i < nx
    for (int j = 1; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
            psix_of_[std::size_t(j) * std::size_t(nx) + std::size_t(i)] = n++;
    const std::ptrdiff_t npx = n - nw;
    psiy_of_.assign(std::size_t(nx + 1) * std::size_t(ny), -1); // (i, j), j < ny
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
    lambda_ = largest_generalized_eigenvalue(stiffness_, mass_);
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

double MindlinOperator::max_time_step() const { return 2.0 / std::sqrt(lambda_max()); }

} // namespace calib::engine::mindlin
