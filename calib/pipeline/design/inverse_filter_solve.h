// The inverse filter's solve, shared by its designs (inverse_filter.cpp: one
// design and its minimax refinement), the designs of a scene's foci that
// share their correlations (shared_designs.h) and their price
// (inverse_filter_cost.h). Internal to pipeline/design/.
#pragma once
#include "pipeline/design/block_toeplitz.h"
#include "pipeline/design/inverse_filter.h"
#include "pipeline/signal/peaks.h"
#include "pipeline/signal/real_fft.h"

#include <Eigen/Dense>

#include <cmath>
#include <complex>
#include <cstddef>
#include <vector>

namespace calib::pipeline::inverse_solve {

using Complex = std::complex<double>;

// Right-hand side: W_f A_f^T d summed over the plates and the foci,
// b[(c,j)] = W_f sum_m sum_f sum_n h^m_cf[n] d[n + j].
Eigen::VectorXd focus_rhs(const Plates &plates, const InverseFilterProblem &p, const InverseFilterOptions &o);

// The penalty per unit beta as a function of the lag j - jj (+ J - 1):
// I + rho P_out, P_out[l] = delta_l - 2 nu sinc(2 nu l), the drive's energy
// above nu = band_edge / R cycles per sample.
std::vector<double> penalty_lags(const InverseFilterOptions &o, double rate_hz, std::size_t J);

// The same design from R (summed_correlations) without forming G: lambda_max
// and the solve through ToeplitzOperator and BlockLevinson, G formed and
// factored only where those do not get there (then as solve_design).
InverseFilterDesign toeplitz_design(const Eigen::VectorXd &R, const Eigen::VectorXd &b, const std::vector<double> &pen,
                                    double regularization, std::size_t C, std::size_t J, double rate_hz, RealFft &fft,
                                    BlockLevinson &lev);

void check_plates(const Plates &plates);

// Lawson's refinement (minimax_design): `design` maps the control weights to
// a design, `fields` a drive to, per plate, the field at the Q control points
// then at the foci.
template <typename Design, typename Fields>
InverseFilterDesign lawson(std::size_t Q, int iterations, std::vector<double> &weights, Design design, Fields fields)
{
    weights.assign(Q, 1.0);
    InverseFilterDesign best;
    double best_ratio = -1;
    for (int it = 0; it <= iterations; it++) {
        InverseFilterDesign d = design(weights);
        // Per control point its largest |w| over time relative to its plate's
        // focal peak (the weakest focus's), the largest over the plates (what
        // the worst plate's contrast sees; a plate that is louder overall does
        // not count as worse). One plate: |w| itself (the same weights, bit
        // for bit).
        const std::vector<std::vector<std::vector<float>>> ws = fields(d.drive);
        std::vector<double> m(Q, 0.0);
        double worst = 0, focal = 1;
        for (const auto &w : ws) {
            focal = INFINITY;
            for (std::size_t i = Q; i < w.size(); i++)
                focal = std::min(focal, sample_peak(w[i].data(), w[i].size()));
            const double scale = ws.size() > 1 ? 1 / std::max(focal, 1e-300) : 1.0;
            for (std::size_t q = 0; q < Q; q++)
                m[q] = std::max(m[q], sample_peak(w[q].data(), w[q].size()) * scale);
        }
        for (std::size_t q = 0; q < Q; q++)
            worst = std::max(worst, m[q]);
        // The focal peak over the worst control point (of the worst plate).
        const double ratio = (ws.size() > 1 ? 1.0 : focal) / std::max(worst, 1e-300);
        if (ratio > best_ratio) {
            best_ratio = ratio;
            best = std::move(d);
        }
        if (!(worst > 0))
            break;
        double sum = 0;
        for (std::size_t q = 0; q < Q; q++)
            sum += (weights[q] *= m[q] / worst);
        for (double &v : weights)
            v *= double(Q) / sum;
    }
    return best;
}

} // namespace calib::pipeline::inverse_solve
