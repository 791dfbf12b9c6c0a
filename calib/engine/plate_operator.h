// The plate *operator*: everything precomputed from material, geometry, edges
// and grid before time stepping starts (openEMS's operator/engine split).
//
// The scheme is built from its discrete energy (Bilbao, Numerical Sound
// Synthesis, ch. 12), so every edge combination has a conserved energy by
// construction:
//
//   kinetic   T = 1/2 (du/dt)^T M (du/dt),    M = rho d h^2 diag(w)
//   potential V = 1/2 u^T K u,
//   K = D h^2 [ sum_nodes  w_n q_n(dxx u, dyy u) + sum_cells 2 (1 - nu) (dxy u)^2 ]
//
// with trapezoid weights w (1/2 on a free edge, 1/4 on a free corner), the
// node form q = a^2 + b^2 + 2 nu a b, and the cell twist dxy = d_x+ d_y+ u at
// cell centres. On a supported edge u = 0 and the ghost node is u_-1 = -u_1
// (simply supported) or +u_1 (clamped); on a free edge the normal second
// difference is eliminated by the zero-moment condition a = -nu b, which
// leaves q = (1 - nu^2) b^2; the zero-shear and corner conditions then follow
// from the variation of V. Inside (two nodes away from every edge) the rows
// of M^-1 K are exactly kappa^2 times Bilbao's 13-point biharmonic, whatever
// nu is; only the rows near the edges differ, and the engine applies those as
// sparse rows.
//
// Loss (optional): rho d u_tt = -D (lap^2) u - 2 sigma0 rho d u_t + 2 sigma1 rho d lap u_t,
// with the sigma1 term as a backward difference in time so the update stays
// explicit; Gm is the matching energy-consistent (Neumann on free edges)
// Dirichlet form so that M^-1 Gm = -laplacian in the interior.
#pragma once

#include "physics/material.h"

#include <Eigen/SparseCore>

#include <array>
#include <cstddef>
#include <numbers>
#include <string>
#include <mutex>
#include <vector>

namespace calib::engine {

enum class EdgeKind { clamped, simply_supported, free };
const char *edge_kind_name(EdgeKind kind);

// Edges of the rectangle [0, Lx] x [0, Ly]: left x = 0, right x = Lx,
// bottom y = 0, top y = Ly.
struct Edges {
    EdgeKind left = EdgeKind::clamped;
    EdgeKind right = EdgeKind::clamped;
    EdgeKind bottom = EdgeKind::clamped;
    EdgeKind top = EdgeKind::clamped;
    static Edges all(EdgeKind k) { return {k, k, k, k}; }
    // No free edge (every edge clamped or simply supported): the plate has no
    // rigid-body mode, a uniform mass, and rows next to its edges that are the
    // interior stencil mirrored across them (PlateOperator::mirror_edges()).
    bool none_free() const
    {
        return left != EdgeKind::free && right != EdgeKind::free && bottom != EdgeKind::free && top != EdgeKind::free;
    }
};

// Frequency-dependent loss of the PDE above (1/s and m^2/s).
struct Loss {
    double sigma0 = 0;
    double sigma1 = 0;
    bool active() const { return sigma0 != 0 || sigma1 != 0; }
    // The amplitude decay rate (1/s) of a wave of angular frequency omega on a
    // plate of constant kappa: sigma(omega) = sigma0 + sigma1 beta^2, beta^2 = omega / kappa.
    double decay_rate_1_s(double omega_rad_s, double kappa_m2_s) const
    {
        return sigma0 + sigma1 * omega_rad_s / kappa_m2_s;
    }
};

// T60 (s: a 60 dB fall of the *amplitude*) and the amplitude decay rate sigma
// (1/s) of exp(-sigma t): T60 = 3 ln(10) / sigma, either way. (Bilbao writes
// 6 ln(10) with his convention; we state ours and test it by measuring the decay.)
inline double t60_of_decay_rate_s(double rate_1_s) { return 3 * std::numbers::ln10 / rate_1_s; }
inline double decay_rate_of_t60_1_s(double t60_s) { return 3 * std::numbers::ln10 / t60_s; }

// Loss from two T60 values at two frequencies: a mode of wavenumber beta
// decays as exp(-(sigma0 + sigma1 beta^2) t), so each T60_i gives
// sigma(omega_i) (Loss::decay_rate_1_s, decay_rate_of_t60_1_s) and the two
// fix sigma0 and sigma1. Throws std::invalid_argument if the fit needs a
// negative sigma (T60 must not grow with frequency faster than the model
// allows) or an input is not positive.
Loss loss_from_t60(double kappa_m2_s, double f1_hz, double t60_1_s, double f2_hz, double t60_2_s);

struct PlateParams {
    double size_x_m = 0;
    double size_y_m = 0;
    double thickness_m = 0;
    physics::Material material;
    Edges edges;
    Loss loss;
};

// Node grid: nx x ny intervals of the same spacing h; nodes (i, j) with
// 0 <= i <= nx, 0 <= j <= ny at x = i h, y = j h.
struct Grid {
    int nx = 0;
    int ny = 0;
    double h = 0;
    double length_x_m() const { return nx * h; }
    double length_y_m() const { return ny * h; }
    std::size_t node_count() const { return std::size_t(nx + 1) * std::size_t(ny + 1); }
    std::size_t node(int i, int j) const { return std::size_t(j) * std::size_t(nx + 1) + std::size_t(i); }
};

// The largest h <= h_max that divides size_x into whole intervals; size_y
// gets the nearest whole number of intervals (the plate is |dy| <= h/2 off).
Grid make_grid(double size_x_m, double size_y_m, double h_max_m);

class PlateOperator {
  public:
    using SparseMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

    // Throws std::invalid_argument on non-positive sizes or grids below 2x2
    // intervals.
    PlateOperator(const PlateParams &params, const Grid &grid);

    const PlateParams &params() const { return params_; }
    const Grid &grid() const { return grid_; }
    double kappa() const { return kappa_; }
    double bending_stiffness() const { return bending_stiffness_; }

    // Unknowns: nodes not held at zero by a supported edge. unknown_of[node]
    // is the unknown's index or -1; node_of[unknown] the reverse.
    std::size_t unknown_count() const { return node_of_.size(); }
    const std::vector<std::ptrdiff_t> &unknown_of() const { return unknown_of_; }
    const std::vector<std::size_t> &node_of() const { return node_of_; }
    bool is_fixed(int i, int j) const { return unknown_of_[grid_.node(i, j)] < 0; }

    // Over the unknowns: M (kg, diagonal), K (N/m), Gm (kg/m^2... so that
    // M^-1 Gm = -laplacian inside). All symmetric; K and Gm positive
    // semi-definite.
    const Eigen::VectorXd &mass() const { return mass_; }
    // Assembled on first use (thread-safe), with the edge terms below: an
    // engine on clamped and supported edges never needs them (it steps the
    // mirrored stencil, and the bound is the interior one); on 997 x 997
    // they took about 4 s and 2.8 GB.
    const SparseMatrix &stiffness() const
    {
        assemble_matrices();
        return stiffness_;
    }
    const SparseMatrix &dirichlet() const
    {
        assemble_matrices();
        return dirichlet_;
    }
    // Every edge clamped or simply supported, and a uniform mass: the rows next
    // to the edges are the mirrored interior stencil (engine/plate_engine.cpp).
    bool mirror_edges() const { return mirror_edges_; }

    // Largest eigenvalue of M^-1 K and M^-1 Gm (1/s^2 and 1/m^2-ish): exact for
    // small grids, Lanczos otherwise. Computed once, lazily.
    double lambda_max_stiffness() const;
    double lambda_max_dirichlet() const;
    // The largest stable time step: k^2/4 lambda_K + sigma1 k lambda_G <= 1
    // (the energy stays positive definite; sufficient, and exact without
    // loss). Strictly, the scheme is stable below this value.
    double max_time_step() const;
    // Throws std::invalid_argument naming the bound if k >= max_time_step().
    void check_time_step(double k) const;

    // Bilinear spreading weights of a point (metres) on the node grid: up to 4
    // (node, weight) pairs, fixed nodes dropped. Throws if outside the plate.
    struct NodeWeight {
        std::size_t node;
        double weight;
    };
    std::vector<NodeWeight> point_weights(double x_m, double y_m) const;

    // Mass weight w of a node (1, 1/2, 1/4; 0 for a fixed node).
    double mass_weight(int i, int j) const;

    // The edge band: nodes within one cell of an edge, whose rows of M^-1 K
    // differ from the interior 13-point stencil (the engine applies them as
    // sparse rows; the rest is its bulk kernel).
    bool in_edge_band(int i, int j) const { return i < 2 || i > grid_.nx - 2 || j < 2 || j > grid_.ny - 2; }

    // K and Gm as the sums they are built from, restricted to the terms that
    // touch the edge band:  sum_f weight_f (a_f b_f^T + b_f a_f^T) / 2  over
    // difference stencils ("strains": second differences at nodes, twists at
    // cell centres, first differences on links). A stencil has small integer
    // weights on nodes (fixed nodes left out) times one scale (1/h^2 or 1/h),
    // so applied in float it still annihilates exactly what the difference
    // annihilates (a free plate's 1, x, y), whatever the rounding of the
    // weights and scales around it (docs/engine.md, "Rigid-body modes in
    // float").
    struct Stencil {
        std::array<std::size_t, 4> node{};
        std::array<int, 4> weight{};
        int count = 0;
        double scale = 0;
    };
    struct FormTerm {
        std::size_t a = 0, b = 0; // indices into edge_stencils()
        double weight = 0;
    };
    const std::vector<Stencil> &edge_stencils() const
    {
        assemble_matrices();
        return edge_stencils_;
    }
    const std::vector<FormTerm> &edge_stiffness_terms() const
    {
        assemble_matrices();
        return edge_stiffness_terms_;
    }
    const std::vector<FormTerm> &edge_dirichlet_terms() const
    {
        assemble_matrices();
        return edge_dirichlet_terms_;
    }

  private:
    // The unknowns and the mass (the constructor, `form` false); the form, its
    // sparse matrices and the edge band's factored terms (`form` true: once,
    // on first use, through assemble_matrices()).
    void assemble(bool form);
    void assemble_matrices() const;

    PlateParams params_;
    Grid grid_;
    double kappa_ = 0;
    double bending_stiffness_ = 0;
    std::vector<std::ptrdiff_t> unknown_of_;
    std::vector<std::size_t> node_of_;
    Eigen::VectorXd mass_;
    mutable SparseMatrix stiffness_;
    mutable SparseMatrix dirichlet_;
    mutable std::once_flag matrices_once_;
    bool mirror_edges_ = false;
    mutable std::vector<Stencil> edge_stencils_; // with the matrices, on first use
    mutable std::vector<FormTerm> edge_stiffness_terms_, edge_dirichlet_terms_;
    mutable double lambda_k_ = -1;
    mutable double lambda_g_ = -1;
};

} // namespace calib::engine
