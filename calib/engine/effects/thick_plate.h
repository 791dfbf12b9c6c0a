// The thick-plate effect: a Mindlin-Reissner plate (shear deformation and
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
// beta replaced by (2/h) sin(beta h / 2) (second order in h).
#pragma once

#include "engine/effects/effects.h"
#include "engine/plate_operator.h"
#include "physics/dispersion.h"

#include <Eigen/SparseCore>

#include <cstddef>
#include <memory>
#include <vector>

namespace calib::engine::effects {

class MindlinOperator {
public:
    using SparseMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

    // Throws std::invalid_argument for free edges, loss, or a grid under 2 x 2.
    MindlinOperator(const PlateParams &params, const Grid &grid,
                    physics::MindlinShear shear = physics::MindlinShear::pi2_over_12);

    const PlateParams &params() const { return params_; }
    const Grid &grid() const { return grid_; }
    double shear_stiffness() const { return shear_; }  // k_s^2 G d (N/m)

    // Unknowns: [w (interior nodes) | psi_x | psi_y].
    std::size_t unknown_count() const { return std::size_t(mass_.size()); }
    std::size_t w_count() const { return w_node_.size(); }
    // Unknown index of w at node (i, j), psi_x at ((i+1/2) h, j h), psi_y at (i h, (j+1/2) h); -1 if held.
    std::ptrdiff_t w_index(int i, int j) const;
    std::ptrdiff_t psi_x_index(int i, int j) const;
    std::ptrdiff_t psi_y_index(int i, int j) const;

    const Eigen::VectorXd &mass() const { return mass_; }
    const SparseMatrix &stiffness() const { return stiffness_; }
    double lambda_max() const;     // of M^-1 K (computed once)
    double max_time_step() const;  // 2 / sqrt(lambda_max)

private:
    PlateParams params_;
    Grid grid_;
    double shear_ = 0;
    std::vector<std::ptrdiff_t> w_of_node_, psix_of_, psiy_of_;
    std::vector<std::size_t> w_node_;
    Eigen::VectorXd mass_;
    SparseMatrix stiffness_;
    mutable double lambda_ = -1;
};

// Leapfrog time stepping of a MindlinOperator (double precision).
class MindlinEngine {
public:
    // Throws std::invalid_argument if time_step_s is not below the bound.
    MindlinEngine(std::shared_ptr<const MindlinOperator> op, double time_step_s);

    const MindlinOperator &plate() const { return *op_; }
    double time_step() const { return k_; }
    std::size_t steps_done() const { return steps_; }

    std::size_t add_source(double x_m, double y_m);    // point force on w, bilinear
    std::size_t add_receiver(double x_m, double y_m);  // w, same weights
    void set_source_force(std::size_t s, double force_n) { sources_[s].force = force_n; }
    double receiver_value(std::size_t r) const;

    // The finger (effects.h) on w at its point: the same exact coupled
    // solve as FingerExtension (finger.h), with the mass-scaled source
    // weights as the displacement per newton. Throws std::invalid_argument
    // off the plate, on held nodes only, or for a spring the step cannot take.
    std::size_t add_finger(const FingerSpec &spec);
    double finger_force_n(std::size_t f) const { return fingers_[f].force; }

    void step();
    double energy() const;  // J, at n+1/2 (the plate's; a finger's own energy is not included)

    // Unknown vectors (layout of MindlinOperator) for q^n and q^{n-1}.
    const Eigen::VectorXd &state() const { return cur_; }
    void set_state(const Eigen::VectorXd &current, const Eigen::VectorXd &previous);

private:
    struct Tap {
        std::vector<Eigen::Index> index;
        std::vector<double> weight;
        double force = 0;
    };
    struct Finger {
        FingerSpec spec;
        Tap phi;                  // interpolation weights
        std::vector<double> gain; // phi * k^2 / M: displacement per newton
        double g = 0;             // phi^T gain
        double force = 0;
    };
    Tap tap_at(double x_m, double y_m, bool scale_by_mass) const;
    void apply_finger(Finger &f);

    std::shared_ptr<const MindlinOperator> op_;
    double k_ = 0;
    std::size_t steps_ = 0;
    MindlinOperator::SparseMatrix update_;  // k^2 M^-1 K
    Eigen::VectorXd prev_, cur_, next_;
    std::vector<Tap> sources_, receivers_;
    std::vector<Finger> fingers_;
};

}  // namespace calib::engine::effects
