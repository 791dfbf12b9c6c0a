// Free vibration of the plate operator: the lowest eigenpairs of
//
//   K v = omega^2 M v
//
// with K and M of plate_operator.h (K symmetric positive semi-definite, M a
// positive diagonal). These are the modes of the spatially discrete plate
// (continuous in time); the time-stepping scheme runs each of them at
// (2 / k) asin(k omega / 2), slightly above omega. The generalized problem is
// solved as the standard symmetric one for A = M^-1/2 K M^-1/2 (A y = omega^2 y,
// v = M^-1/2 y, so v^T M v = 1): implicitly restarted Lanczos (Spectra) in
// shift-invert mode with a sparse Cholesky factor of K - sigma M. The shift
// sigma is negative, so K - sigma M is positive definite even for a free
// plate, whose three rigid-body modes (translation, two tilts) sit at 0.
#pragma once

#include "engine/plate_operator.h"

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace calib::engine {

// A mode's parity under the plate's mirror symmetry about x = Lx/2 or
// y = Ly/2 (only when the two mirrored edges have the same condition).
enum class Parity { symmetric, antisymmetric, mixed, not_applicable };
const char *parity_name(Parity p); // "sym", "anti", "mixed", "-"

struct PlateModes {
    std::vector<double> eigenvalue_rad2_s2; // omega^2, ascending (~0 for rigid-body modes; may be -1e-12-ish)
    std::vector<double> frequency_hz;       // sqrt(max(omega^2, 0)) / 2 pi
    // Amplitude decay rate of each mode with the operator's loss, to first
    // order in the loss: sigma0 + sigma1 v^T Gm v (v^T M v = 1); for a simply
    // supported plate exactly sigma0 + sigma1 times the discrete -laplacian's
    // eigenvalue. 0 without loss.
    std::vector<double> decay_rate_1_s;
    std::vector<Parity> parity_x, parity_y;
    // Unknowns x modes, M-orthonormal. Within a degenerate group (a square's
    // (m, n) and (n, m)) the vectors are rotated to be mirror-symmetric or
    // antisymmetric where the edges allow it.
    Eigen::MatrixXd shapes;
    long iterations = 0; // Lanczos restarts
    long operations = 0; // solves with the factor
};

// The `count` lowest modes. Throws std::invalid_argument unless
// 1 <= count < op.unknown_count(), std::runtime_error if the factorisation
// or the iteration fails (one line each).
PlateModes lowest_modes(const PlateOperator &op, int count);

// An upper estimate of the memory lowest_modes needs beyond the operator
// (bytes): the shifted matrix, its Cholesky factor (fill-in of the
// minimum-degree ordering on a 13-point grid, measured), the Lanczos basis
// and the shapes. And of the operator itself (its assembly peak), from the
// node count alone, so a job is refused before anything is built.
double lowest_modes_bytes(std::size_t unknowns, int count);
double plate_operator_bytes(std::size_t nodes);

// A mode shape on the node grid, row-major (j, i), 0 at fixed nodes, scaled
// to max |w| = 1 with the largest value positive (a reproducible sign).
std::vector<double> mode_field(const PlateOperator &op, const Eigen::Ref<const Eigen::VectorXd> &shape);

} // namespace calib::engine
