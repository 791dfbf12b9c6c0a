// The thick-plate operator: a Mindlin-Reissner plate (shear deformation and
// rotary inertia), for high f*d where Kirchhoff's A0 is too fast (ultrasonic
// haptics on 5-10 mm glass: Kirchhoff is 5-10 % off at 20-40 kHz, Mindlin
// ~0.5 %; docs/effects.md).
//
// Unknowns on staggered grids (all at integer time levels): w at the nodes
// (i h, j h), psi_x at ((i+1/2) h, j h), psi_y at (i h, (j+1/2) h). Every
// strain then sits where its differences are centred: shear gamma_x =
// dw/dx + psi_x at the psi_x points, gamma_y at the psi_y points, bending
// curvatures dpsi_x/dx, dpsi_y/dy at the nodes, twist dpsi_x/dy + dpsi_y/dx at
// the cell centres. The scheme is built from its discrete energy, as the
// Kirchhoff operator is:
//
//   T = 1/2 h^2 sum [rho d w_t^2 + rho d^3/12 (psi_x,t^2 + psi_y,t^2)]
//   V = 1/2 h^2 sum [D w_n ((1+nu)/2 (kxx + kyy)^2 + (1-nu)/2 (kxx - kyy)^2)
//                    + D (1-nu)/2 kxy^2 + k_s^2 G d (gamma_x^2 + gamma_y^2)]
//
// V = 1/2 q^T K q with K = h^2 B^T C B (B: strains from unknowns, C >= 0
// diagonal), M diagonal; leapfrog q+ = 2q - q- - k^2 M^-1 K q conserves
// H = 1/2 |q+ - q|_M^2 / k^2 + 1/2 q+^T K q exactly and is stable iff
// k^2 / 4 lambda_max(M^-1 K) < 1: its own bound, set by the shear wave
// (k ~ h / c_T) and the thickness-shear frequency (k < 2 / omega_c), not by
// the Kirchhoff h^2 / kappa. Edges: simply supported (hard: w = 0 and the
// tangential rotation is 0, the normal moment vanishes by a symmetric ghost)
// or clamped (w = 0, psi = 0: antisymmetric ghost, half weight), per edge.
// Free edges and loss are not implemented (refused).
//
// On a simply supported plate the discrete modes are exactly sin/cos
// products, and the scheme's dispersion is Mindlin's with the wavenumber
// beta replaced by (2/h) sin(beta h / 2) (second order in h). Its engine is
// mindlin_engine.h; a scene asks for it with [effects] thick_plate
// (scene::build_plate builds the operator once, every simulation of the plate
// shares it).
#pragma once

#include "engine/plate_operator.h"
#include "physics/dispersion.h"

#include <Eigen/SparseCore>

#include <cstddef>
#include <vector>

namespace calib::engine::mindlin {

class MindlinOperator {
  public:
    using SparseMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

    // Assembles K and M and finds the stability bound (Lanczos, on this
    // thread), so a built operator is read-only and shared by simulations
    // running in parallel. Throws std::invalid_argument for free edges, loss,
    // or a grid under 2 x 2.
    MindlinOperator(const PlateParams &params, const Grid &grid,
                    physics::MindlinShear shear = physics::MindlinShear::pi2_over_12);

    const PlateParams &params() const { return params_; }
    const Grid &grid() const { return grid_; }
    double shear_stiffness() const { return shear_; } // k_s^2 G d (N/m)

    // Unknowns: [w (interior nodes) | psi_x | psi_y].
    std::size_t unknown_count() const { return std::size_t(mass_.size()); }
    std::size_t w_count() const { return w_node_.size(); }
    // Unknown index of w at node (i, j), psi_x at ((i+1/2) h, j h), psi_y at (i h, (j+1/2) h); -1 if held.
    std::ptrdiff_t w_index(int i, int j) const;
    std::ptrdiff_t psi_x_index(int i, int j) const;
    std::ptrdiff_t psi_y_index(int i, int j) const;

    const Eigen::VectorXd &mass() const { return mass_; }
    const SparseMatrix &stiffness() const { return stiffness_; }
    double lambda_max() const { return lambda_; } // of M^-1 K
    double max_time_step() const;                 // 2 / sqrt(lambda_max)

  private:
    PlateParams params_;
    Grid grid_;
    double shear_ = 0;
    std::vector<std::ptrdiff_t> w_of_node_, psix_of_, psiy_of_;
    std::vector<std::size_t> w_node_;
    Eigen::VectorXd mass_;
    SparseMatrix stiffness_;
    double lambda_ = 0;
};

} // namespace calib::engine::mindlin
