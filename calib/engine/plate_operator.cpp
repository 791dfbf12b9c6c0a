#include "engine/plate_operator.h"

#include "engine/spectrum.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

namespace calib::engine {

const char *edge_kind_name(EdgeKind kind)
{
    switch (kind) {
    case EdgeKind::clamped:
        return "clamped";
    case EdgeKind::simply_supported:
        return "simply_supported";
    case EdgeKind::free:
        return "free";
    }
    return "?";
}

Loss loss_from_t60(double kappa, double f1, double t1, double f2, double t2)
{
    if (!(kappa > 0) || !(f1 > 0) || !(f2 > 0) || !(t1 > 0) || !(t2 > 0))
        throw std::invalid_argument("loss: frequencies and T60 values must be > 0");
    if (f1 == f2)
        throw std::invalid_argument("loss: the two frequencies must differ");
    if (f1 > f2) {
        std::swap(f1, f2);
        std::swap(t1, t2);
    }
    const double xi1 = 2 * std::numbers::pi * f1 / kappa; // beta^2 = omega / kappa
    const double xi2 = 2 * std::numbers::pi * f2 / kappa;
    const double s1 = decay_rate_of_t60_1_s(t1); // amplitude decay rates
    const double s2 = decay_rate_of_t60_1_s(t2);
    Loss loss;
    loss.sigma1 = (s2 - s1) / (xi2 - xi1);
    loss.sigma0 = s1 - loss.sigma1 * xi1;
    // An exact 1/f law (T60 proportional to 1/f, a constant loss factor) has
    // sigma0 = 0 in exact arithmetic; the subtraction above leaves a round-off
    // residue of either sign, a few ulps of s1. That is zero, not a law that
    // falls faster than 1/f.
    if (std::abs(loss.sigma0) <= 1e-12 * s1)
        loss.sigma0 = 0;
    if (loss.sigma1 < 0) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "loss: T60 must not grow with frequency (%g s at %g Hz, %g s at %g Hz)", t1, f1,
                      t2, f2);
        throw std::invalid_argument(buf);
    }
    if (loss.sigma0 < 0) {
        char buf[240];
        std::snprintf(buf, sizeof buf,
                      "loss: T60 falls faster than 1/f (%g s at %g Hz, %g s at %g Hz) which needs sigma0 < 0; "
                      "the model sigma0 + sigma1*omega/kappa cannot represent it",
                      t1, f1, t2, f2);
        throw std::invalid_argument(buf);
    }
    return loss;
}

Grid make_grid(double size_x_m, double size_y_m, double h_max_m)
{
    if (!(size_x_m > 0) || !(size_y_m > 0) || !(h_max_m > 0))
        throw std::invalid_argument("grid: plate sizes and spacing must be > 0");
    Grid g;
    g.nx = std::max(2, int(std::ceil(size_x_m / h_max_m - 1e-9)));
    g.h = size_x_m / g.nx;
    g.ny = std::max(2, int(std::lround(size_y_m / g.h)));
    return g;
}

namespace {

struct Term {
    int i, j;
    double c;
};
using Row = std::vector<Term>;

// Second difference along one axis at index `a` of [0, n]: interior, or an
// edge with its ghost rule. Returns false when the edge is free (the
// difference is eliminated by the zero-moment condition).
bool second_difference(int a, int n, EdgeKind low, EdgeKind high, double inv_h2,
                       std::vector<std::pair<int, double>> &out)
{
    out.clear();
    if (a > 0 && a < n) {
        out = {{a - 1, inv_h2}, {a, -2 * inv_h2}, {a + 1, inv_h2}};
        return true;
    }
    const EdgeKind kind = a == 0 ? low : high;
    const int inner = a == 0 ? 1 : n - 1;
    switch (kind) {
    case EdgeKind::free:
        return false;
    case EdgeKind::clamped:
        out = {{a, -2 * inv_h2}, {inner, 2 * inv_h2}};
        return true; // ghost = +u_inner
    case EdgeKind::simply_supported:
        out = {{a, -2 * inv_h2}};
        return true; // ghost = -u_inner
    }
    return false;
}

} // namespace

PlateOperator::PlateOperator(const PlateParams &params, const Grid &grid) : params_(params), grid_(grid)
{
    if (grid.nx < 2 || grid.ny < 2 || !(grid.h > 0))
        throw std::invalid_argument("plate grid needs at least 2 x 2 intervals and h > 0");
    if (!(params.thickness_m > 0))
        throw std::invalid_argument("plate thickness must be > 0");
    if (params.loss.sigma0 < 0 || params.loss.sigma1 < 0)
        throw std::invalid_argument("plate loss coefficients must be >= 0");
    bending_stiffness_ = params.material.bending_stiffness(params.thickness_m);
    kappa_ = params.material.kappa(params.thickness_m);
    assemble(false);
    mirror_edges_ = params_.edges.none_free() && mass_.maxCoeff() == mass_.minCoeff();
}

void PlateOperator::assemble_matrices() const
{
    std::call_once(matrices_once_, [this] { const_cast<PlateOperator *>(this)->assemble(true); });
}

double PlateOperator::mass_weight(int i, int j) const
{
    if (is_fixed(i, j))
        return 0.0;
    const double wx = (i == 0 || i == grid_.nx) ? 0.5 : 1.0;
    const double wy = (j == 0 || j == grid_.ny) ? 0.5 : 1.0;
    return wx * wy;
}

void PlateOperator::assemble(bool form)
{
    const int nx = grid_.nx, ny = grid_.ny;
    const double h = grid_.h;
    const Edges &e = params_.edges;
    const double nu = params_.material.poisson;
    const double rho_d = params_.material.density_kg_m3 * params_.thickness_m;

    if (!form) {
        unknown_of_.assign(grid_.node_count(), -1);
        node_of_.clear();
        for (int j = 0; j <= ny; ++j)
            for (int i = 0; i <= nx; ++i) {
                const bool fixed = (i == 0 && e.left != EdgeKind::free) || (i == nx && e.right != EdgeKind::free) ||
                                   (j == 0 && e.bottom != EdgeKind::free) || (j == ny && e.top != EdgeKind::free);
                if (!fixed) {
                    unknown_of_[grid_.node(i, j)] = std::ptrdiff_t(node_of_.size());
                    node_of_.push_back(grid_.node(i, j));
                }
            }
        const Eigen::Index n = Eigen::Index(node_of_.size());
        if (n == 0)
            throw std::invalid_argument("plate grid has no free nodes (too coarse for its edges)");

        mass_.resize(n);
        for (Eigen::Index u = 0; u < n; ++u) {
            const std::size_t node = node_of_[std::size_t(u)];
            const int i = int(node % std::size_t(nx + 1)), j = int(node / std::size_t(nx + 1));
            mass_[u] = rho_d * h * h * mass_weight(i, j);
        }
        edge_stencils_.clear();
        edge_stiffness_terms_.clear();
        edge_dirichlet_terms_.clear();
        return; // the form (the matrices and the edge terms) on first use
    }
    const Eigen::Index n = Eigen::Index(node_of_.size());
    // Terms of the factored form that touch the edge band, with their
    // stencils (every coefficient an integer times scale). A stencil is kept
    // once per node or cell: `id` caches it (-1: not yet made).
    auto touches_band = [&](const Row &r) {
        return std::any_of(r.begin(), r.end(), [&](const Term &t) {
            return unknown_of_[grid_.node(t.i, t.j)] >= 0 && in_edge_band(t.i, t.j);
        });
    };
    auto edge_stencil = [&](const Row &r, double scale, std::ptrdiff_t &id) {
        if (id >= 0)
            return std::size_t(id);
        Stencil st;
        st.scale = scale;
        for (const Term &t : r) {
            if (unknown_of_[grid_.node(t.i, t.j)] < 0)
                continue;
            st.node[std::size_t(st.count)] = grid_.node(t.i, t.j);
            st.weight[std::size_t(st.count)] = int(std::lround(t.c / scale));
            ++st.count;
        }
        edge_stencils_.push_back(st);
        id = std::ptrdiff_t(edge_stencils_.size() - 1);
        return std::size_t(id);
    };
    auto edge_term = [&](std::vector<FormTerm> &terms, const Row &ra, std::ptrdiff_t &ia, const Row &rb,
                         std::ptrdiff_t &ib, double scale, double weight) {
        if (touches_band(ra) || touches_band(rb))
            terms.push_back({edge_stencil(ra, scale, ia), edge_stencil(rb, scale, ib), weight});
    };

    std::vector<Eigen::Triplet<double>> tk, tg;
    // Adds scale * (r1 r2^T + r2 r1^T)/2 (symmetric outer product) over the unknowns.
    auto add_outer = [&](std::vector<Eigen::Triplet<double>> &t, const Row &r1, const Row &r2, double scale) {
        for (const Term &a : r1) {
            const std::ptrdiff_t ua = unknown_of_[grid_.node(a.i, a.j)];
            if (ua < 0)
                continue;
            for (const Term &b : r2) {
                const std::ptrdiff_t ub = unknown_of_[grid_.node(b.i, b.j)];
                if (ub < 0)
                    continue;
                const double v = 0.5 * scale * a.c * b.c;
                t.emplace_back(Eigen::Index(ua), Eigen::Index(ub), v);
                t.emplace_back(Eigen::Index(ub), Eigen::Index(ua), v);
            }
        }
    };

    const double inv_h2 = 1.0 / (h * h);
    const double dh2 = bending_stiffness_ * h * h;
    std::vector<std::pair<int, double>> dx, dy;
    for (int j = 0; j <= ny; ++j)
        for (int i = 0; i <= nx; ++i) {
            const double w = ((i == 0 || i == nx) ? 0.5 : 1.0) * ((j == 0 || j == ny) ? 0.5 : 1.0);
            const bool has_x = second_difference(i, nx, e.left, e.right, inv_h2, dx);
            const bool has_y = second_difference(j, ny, e.bottom, e.top, inv_h2, dy);
            Row ra, rb;
            for (auto [ii, c] : dx)
                ra.push_back({ii, j, c});
            for (auto [jj, c] : dy)
                rb.push_back({i, jj, c});
            std::ptrdiff_t sa = -1, sb = -1;
            if (has_x && has_y) {
                add_outer(tk, ra, ra, dh2 * w);
                add_outer(tk, rb, rb, dh2 * w);
                add_outer(tk, ra, rb, 2 * nu * dh2 * w);
                edge_term(edge_stiffness_terms_, ra, sa, ra, sa, inv_h2, dh2 * w);
                edge_term(edge_stiffness_terms_, rb, sb, rb, sb, inv_h2, dh2 * w);
                edge_term(edge_stiffness_terms_, ra, sa, rb, sb, inv_h2, 2 * nu * dh2 * w);
            } else if (has_x) {
                add_outer(tk, ra, ra, (1 - nu * nu) * dh2 * w);
                edge_term(edge_stiffness_terms_, ra, sa, ra, sa, inv_h2, (1 - nu * nu) * dh2 * w);
            } else if (has_y) {
                add_outer(tk, rb, rb, (1 - nu * nu) * dh2 * w);
                edge_term(edge_stiffness_terms_, rb, sb, rb, sb, inv_h2, (1 - nu * nu) * dh2 * w);
            }
        }
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
            const Row twist = {{i + 1, j + 1, inv_h2}, {i + 1, j, -inv_h2}, {i, j + 1, -inv_h2}, {i, j, inv_h2}};
            add_outer(tk, twist, twist, 2 * (1 - nu) * dh2);
            std::ptrdiff_t st = -1;
            edge_term(edge_stiffness_terms_, twist, st, twist, st, inv_h2, 2 * (1 - nu) * dh2);
        }
    // Dirichlet form over links, trapezoid-weighted along the boundary.
    const double inv_h = 1.0 / h;
    for (int j = 0; j <= ny; ++j)
        for (int i = 0; i <= nx; ++i) {
            if (i < nx) {
                const double w = (j == 0 || j == ny) ? 0.5 : 1.0;
                const Row r = {{i + 1, j, inv_h}, {i, j, -inv_h}};
                add_outer(tg, r, r, rho_d * h * h * w);
                std::ptrdiff_t sl = -1;
                edge_term(edge_dirichlet_terms_, r, sl, r, sl, inv_h, rho_d * h * h * w);
            }
            if (j < ny) {
                const double w = (i == 0 || i == nx) ? 0.5 : 1.0;
                const Row r = {{i, j + 1, inv_h}, {i, j, -inv_h}};
                add_outer(tg, r, r, rho_d * h * h * w);
                std::ptrdiff_t sl = -1;
                edge_term(edge_dirichlet_terms_, r, sl, r, sl, inv_h, rho_d * h * h * w);
            }
        }
    stiffness_.resize(n, n);
    stiffness_.setFromTriplets(tk.begin(), tk.end());
    stiffness_.prune(0.0);
    dirichlet_.resize(n, n);
    dirichlet_.setFromTriplets(tg.begin(), tg.end());
    dirichlet_.prune(0.0);
}

// Small grids: the exact largest eigenvalue. Large grids: the supremum of the
// interior stencil over the infinite grid (64 kappa^2 / h^4, and 8 / h^2 for
// the Laplacian), which the assembled operator approaches on large grids but
// was never seen to exceed (every edge combination, nu in [-0.5, 0.49]; see
// docs/engine.md). On mirrored edges that is proven (below) and all; with a
// free edge, Lanczos, whose Ritz value approaches lambda_max from below,
// raises it if it finds more. Lanczos was 42 % of a 4 700-step `calibgen
// simulate` on 330 x 330 (docs/engine.md, "Where a step's time goes").
constexpr int dense_eigen_limit = 1200;

namespace {

double bounded_lambda_max(const SparseRowMatrix &a, const Eigen::VectorXd &mass, double supremum)
{
    const double lanczos_or_dense = largest_generalized_eigenvalue(a, mass, dense_eigen_limit);
    return a.rows() <= dense_eigen_limit ? lanczos_or_dense : std::max(lanczos_or_dense, supremum);
}

} // namespace

// Mirrored edges (clamped and supported, uniform mass) past the dense limit:
// every row is the interior stencil with ghost coefficients folded in or
// dropped, so its disc lies inside the interior one (|a + b| <= |a| + |b|)
// and the supremum is the bound without assembling anything (the same value
// Gershgorin's test gives: PlateStability.GershgorinBounds...).
double PlateOperator::lambda_max_stiffness() const
{
    const double sup = 64 * kappa_ * kappa_ / std::pow(grid_.h, 4);
    if (lambda_k_ < 0)
        lambda_k_ =
            mirror_edges_ && mass_.size() > dense_eigen_limit ? sup : bounded_lambda_max(stiffness(), mass_, sup);
    return lambda_k_;
}

double PlateOperator::lambda_max_dirichlet() const
{
    const double sup = 8 / (grid_.h * grid_.h);
    if (lambda_g_ < 0)
        lambda_g_ =
            mirror_edges_ && mass_.size() > dense_eigen_limit ? sup : bounded_lambda_max(dirichlet(), mass_, sup);
    return lambda_g_;
}

double PlateOperator::max_time_step() const
{
    const double a = lambda_max_stiffness() / 4;
    const double b = params_.loss.sigma1 > 0 ? params_.loss.sigma1 * lambda_max_dirichlet() : 0.0;
    return (-b + std::sqrt(b * b + 4 * a)) / (2 * a);
}

void PlateOperator::check_time_step(double k) const
{
    const double kmax = max_time_step();
    if (!(k > 0) || !(k < kmax)) {
        char buf[260];
        std::snprintf(buf, sizeof buf,
                      "time step %.6g s is not below the stability bound %.6g s of the assembled plate operator "
                      "(h = %.4g m, largest eigenvalue of M^-1 K = %.6g 1/s^2)",
                      k, kmax, grid_.h, lambda_max_stiffness());
        throw std::invalid_argument(buf);
    }
}

std::vector<PlateOperator::NodeWeight> PlateOperator::point_weights(double x, double y) const
{
    const double h = grid_.h;
    const double lx = grid_.length_x_m(), ly = grid_.length_y_m();
    const double tol = 0.5 * h;
    if (!(x >= -1e-12 * lx && x <= lx + 1e-12 * lx) || !(y >= -tol && y <= ly + tol)) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "point (%g, %g) m is outside the plate [0, %g] x [0, %g] m", x, y, lx, ly);
        throw std::invalid_argument(buf);
    }
    x = std::clamp(x, 0.0, lx);
    y = std::clamp(y, 0.0, ly);
    const int i0 = std::clamp(int(std::floor(x / h)), 0, grid_.nx - 1);
    const int j0 = std::clamp(int(std::floor(y / h)), 0, grid_.ny - 1);
    const double fx = x / h - i0, fy = y / h - j0;
    std::vector<NodeWeight> out;
    const double wts[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
    const int di[4] = {0, 1, 0, 1}, dj[4] = {0, 0, 1, 1};
    for (int c = 0; c < 4; ++c) {
        if (wts[c] == 0.0 || is_fixed(i0 + di[c], j0 + dj[c]))
            continue;
        out.push_back({grid_.node(i0 + di[c], j0 + dj[c]), wts[c]});
    }
    return out;
}

} // namespace calib::engine
