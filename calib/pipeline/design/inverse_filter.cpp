#include "pipeline/design/inverse_filter.h"
#include "pipeline/design/inverse_filter_solve.h"

#include "pipeline/design/block_toeplitz.h"
#include "pipeline/signal/peaks.h"
#include "pipeline/signal/pulse.h"
#include "pipeline/signal/real_fft.h"
#include "pipeline/transfer/playback.h"

#include <Eigen/Dense>
#include <Spectra/MatOp/DenseSymMatProd.h>
#include <Spectra/SymEigsSolver.h>
#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace inverse_solve {

// Right-hand side: W_f A_f^T d summed over the plates and the foci,
// b[(c,j)] = W_f sum_m sum_f sum_n h^m_cf[n] d[n + j].
Eigen::VectorXd focus_rhs(const Plates &plates, const InverseFilterProblem &p, const InverseFilterOptions &o)
{
    const TransferMatrix &H = *plates.front();
    const std::size_t C = H.channels, S = H.samples, J = p.drive_samples;
    Eigen::VectorXd b = Eigen::VectorXd::Zero(Eigen::Index(C * J));
    for (const TransferMatrix *Hm : plates)
        for (std::size_t f : p.foci)
            for (std::size_t c = 0; c < C; c++) {
                const float *h = Hm->response(c, f);
                for (std::size_t j = 0; j < J; j++) {
                    double acc = 0;
                    for (std::size_t m = 0; m < S && m + j < p.target.size(); m++)
                        acc += double(h[m]) * p.target[m + j];
                    b(Eigen::Index(c * J + j)) += o.focus_weight * acc;
                }
            }
    return b;
}

// The penalty per unit beta as a function of the lag j - jj (+ J - 1):
// I + rho P_out, P_out[l] = delta_l - 2 nu sinc(2 nu l), the drive's energy
// above nu = band_edge / R cycles per sample.
std::vector<double> penalty_lags(const InverseFilterOptions &o, double rate_hz, std::size_t J)
{
    const double nu = o.band_edge_hz > 0 ? std::min(0.5, o.band_edge_hz / rate_hz) : 0.5;
    const double rho = o.band_edge_hz > 0 ? o.out_of_band_weight : 0.0;
    std::vector<double> pen(lag_count(J));
    for (std::size_t i = 0; i < pen.size(); i++) {
        const double l = double(i) - double(J - 1);
        const double x2 = 2 * nu * l;
        const double sinc = l == 0 ? 1.0 : std::sin(std::numbers::pi * x2) / (std::numbers::pi * x2);
        pen[i] = (l == 0 ? 1.0 : 0.0) + rho * ((l == 0 ? 1.0 : 0.0) - 2 * nu * sinc);
    }
    return pen;
}

void check_plates(const Plates &plates)
{
    if (plates.empty() || !plates.front())
        throw std::invalid_argument("inverse filter: no plate");
    const TransferMatrix &H = *plates.front();
    for (const TransferMatrix *m : plates)
        if (!m || m->channels != H.channels || m->samples != H.samples || m->rate_hz != H.rate_hz ||
            m->point_count() != H.point_count() || m->exact_begin() != H.exact_begin())
            throw std::invalid_argument(
                "inverse filter: the stacked plates differ in channels, samples, rate or points");
}

} // namespace inverse_solve

using namespace inverse_solve;

namespace {

// Largest eigenvalue of a symmetric positive semi-definite operator
// (Lanczos; Spectra's operator interface: rows(), perform_op).
template <typename Op>
double lanczos_largest(Op &op)
{
    Spectra::SymEigsSolver<Op> eigs(op, 1, std::min<Eigen::Index>(op.rows(), 20));
    eigs.init();
    eigs.compute(Spectra::SortRule::LargestAlge, 1000, 1e-8);
    if (eigs.info() != Spectra::CompInfo::Successful)
        throw std::runtime_error("inverse filter: the largest eigenvalue of H^T H did not converge");
    return eigs.eigenvalues()[0];
}

// ... of a matrix.
double largest_eigenvalue(const Eigen::MatrixXd &G)
{
    if (G.rows() <= 8) {
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(G, Eigen::EigenvaluesOnly);
        return es.eigenvalues().maxCoeff();
    }
    Spectra::DenseSymMatProd<double> op(G);
    return lanczos_largest(op);
}

// Cross-correlations summed over plates and points with weights:
//   R[k (2J - 1) + l + J - 1] = sum_m sum_p w_p sum_n h^m_cp[n] h^m_c'p[n + l],  |l| < J,
// k the pair (c, c'), from the cross-spectra of the zero-padded responses
// (N >= S + J - 1: no wrap-around within the lags kept).
Eigen::VectorXd summed_correlations(const Plates &plates, const std::vector<std::size_t> &points,
                                    const std::vector<double> &weights, std::size_t J)
{
    const TransferMatrix &H0 = *plates.front();
    const std::size_t C = H0.channels, S = H0.samples, N = next_pow2(S + J - 1), P = points.size();
    const std::size_t pairs = C * (C + 1) / 2;
    std::vector<Complex> total(pairs * N, Complex{});
#pragma omp parallel
    {
        Eigen::FFT<double> fft;
        std::vector<double> buf(N);
        std::vector<std::vector<Complex>> X(C);
        std::vector<Complex> acc(pairs * N, Complex{});
#pragma omp for schedule(dynamic, 8)
        for (std::size_t mi = 0; mi < plates.size() * P; mi++) {
            const TransferMatrix &H = *plates[mi / P];
            const std::size_t i = mi % P;
            for (std::size_t c = 0; c < C; c++) {
                const float *h = H.response(c, points[i]);
                std::fill(buf.begin(), buf.end(), 0.0);
                std::copy(h, h + S, buf.begin());
                fft.fwd(X[c], buf);
            }
            std::size_t k = 0;
            for (std::size_t c = 0; c < C; c++)
                for (std::size_t d = c; d < C; d++, k++)
                    for (std::size_t b = 0; b < N; b++)
                        acc[k * N + b] += weights[i] * std::conj(X[c][b]) * X[d][b];
        }
#pragma omp critical
        for (std::size_t b = 0; b < acc.size(); b++)
            total[b] += acc[b];
    }
    const std::size_t L = lag_count(J);
    Eigen::VectorXd R(Eigen::Index(pairs * L));
    Eigen::FFT<double> fft;
    std::vector<double> out(N);
    std::vector<Complex> spec(N);
    for (std::size_t k = 0; k < pairs; k++) {
        std::copy(total.begin() + long(k * N), total.begin() + long((k + 1) * N), spec.begin());
        fft.inv(out, spec);
        for (std::size_t l = 0; l < L; l++) {
            const long lag = long(l) - long(J - 1);
            R(Eigen::Index(k * L + l)) = out[std::size_t((lag + long(N)) % long(N))];
        }
    }
    return R;
}

// The data part of the normal matrix from R (above):
//   G[(c,j),(d,jj)] = sum_m h_c[m] h_d[m + j - jj].
Eigen::MatrixXd normal_matrix(const Eigen::VectorXd &R, std::size_t C, std::size_t J)
{
    const std::size_t L = lag_count(J), n = C * J;
    Eigen::MatrixXd G(n, n);
    std::size_t k = 0;
    for (std::size_t c = 0; c < C; c++)
        for (std::size_t d = c; d < C; d++, k++) {
            const double *r = R.data() + k * L;
            for (std::size_t j = 0; j < J; j++)
                for (std::size_t jj = 0; jj < J; jj++) {
                    const double v = r[j + J - 1 - jj];
                    G(Eigen::Index(c * J + j), Eigen::Index(d * J + jj)) = v;
                    G(Eigen::Index(d * J + jj), Eigen::Index(c * J + j)) = v;
                }
        }
    return G;
}

// The penalty's blocks added to G: beta (I + rho P_out) per channel.
void add_penalty(Eigen::MatrixXd &G, double beta, const std::vector<double> &pen, std::size_t C, std::size_t J)
{
    for (std::size_t j = 0; j < J; j++)
        for (std::size_t jj = 0; jj < J; jj++) {
            const double v = beta * pen[j + J - 1 - jj];
            for (std::size_t c = 0; c < C; c++)
                G(Eigen::Index(c * J + j), Eigen::Index(c * J + jj)) += v;
        }
}

// Regularised: Cholesky, LDLT if that fails; unregularised: the
// minimum-norm least-squares solution. G with the penalty.
Eigen::VectorXd dense_solve(const Eigen::MatrixXd &G, const Eigen::VectorXd &b, bool regularised)
{
    if (!regularised)
        return G.completeOrthogonalDecomposition().solve(b);
    Eigen::LLT<Eigen::MatrixXd> llt(G);
    if (llt.info() == Eigen::Success)
        return llt.solve(b);
    return G.ldlt().solve(b);
}

// The design from the solution x of the normal equations.
InverseFilterDesign design_of(const Eigen::VectorXd &x, double lambda_max, double beta, std::size_t C, std::size_t J,
                              double rate_hz)
{
    if (!x.allFinite())
        throw std::runtime_error("inverse filter: the solve gave non-finite drives");
    InverseFilterDesign out;
    out.lambda_max = lambda_max;
    out.beta = beta;
    out.drive.assign(C, std::vector<double>(J));
    for (std::size_t c = 0; c < C; c++)
        for (std::size_t j = 0; j < J; j++)
            out.drive[c][j] = x(Eigen::Index(c * J + j)) * rate_hz; // w = (1/R) h * s
    return out;
}

// The regularised design from the data part of G (overwritten).
InverseFilterDesign solve_design(Eigen::MatrixXd &G, const Eigen::VectorXd &b, const std::vector<double> &pen,
                                 double regularization, std::size_t C, std::size_t J, double rate_hz)
{
    const double lambda_max = largest_eigenvalue(G), beta = regularization * lambda_max;
    if (beta > 0)
        add_penalty(G, beta, pen, C, J);
    return design_of(dense_solve(G, b, beta > 0), lambda_max, beta, C, J, rate_hz);
}

} // namespace

// The same design from R (summed_correlations) without forming G: lambda_max
// and the solve through ToeplitzOperator and BlockLevinson, G formed and
// factored only where those do not get there (then as solve_design).
InverseFilterDesign inverse_solve::toeplitz_design(const Eigen::VectorXd &R, const Eigen::VectorXd &b,
                                                   const std::vector<double> &pen, double regularization, std::size_t C,
                                                   std::size_t J, double rate_hz, RealFft &fft, BlockLevinson &lev)
{
    if (C * J <= 8) {
        Eigen::MatrixXd G = normal_matrix(R, C, J);
        return solve_design(G, b, pen, regularization, C, J, rate_hz);
    }
    ToeplitzOperator op(R, C, J, fft);
    const double lambda_max = lanczos_largest(op), beta = regularization * lambda_max;
    Eigen::VectorXd x;
    if (beta > 0) {
        op.regularise(beta, pen);
        if (toeplitz_solve(op, lev, b, x))
            return design_of(x, lambda_max, beta, C, J, rate_hz);
    }
    Eigen::MatrixXd G = normal_matrix(R, C, J);
    if (beta > 0)
        add_penalty(G, beta, pen, C, J);
    return design_of(dense_solve(G, b, beta > 0), lambda_max, beta, C, J, rate_hz);
}

InverseFilterDesign design_inverse_filter(const TransferMatrix &H, const InverseFilterProblem &p,
                                          const InverseFilterOptions &o)
{
    return design_inverse_filter(Plates{&H}, p, o);
}

InverseFilterDesign design_inverse_filter(const Plates &plates, const InverseFilterProblem &p,
                                          const InverseFilterOptions &o)
{
    check_plates(plates);
    const TransferMatrix &H = *plates.front();
    const std::size_t C = H.channels, S = H.samples, J = p.drive_samples;
    if (C == 0 || S == 0 || J == 0 || p.target.empty())
        throw std::invalid_argument("inverse filter: empty problem (no exciters, samples, drive or target)");
    if (p.foci.empty())
        throw std::invalid_argument("inverse filter: no focus");
    for (std::size_t f : p.foci)
        if (f >= H.point_count())
            throw std::invalid_argument("inverse filter: focus point not in the transfer matrix");
    if (!(o.regularization >= 0) || !(o.focus_weight > 0))
        throw std::invalid_argument("inverse filter: regularization must be >= 0 and the focus weight > 0");

    // The data part of the normal matrix: the foci and the control points.
    std::vector<std::size_t> points = p.foci;
    std::vector<double> weights(p.foci.size(), o.focus_weight);
    if (!p.control_weights.empty() && p.control_weights.size() != p.control.size())
        throw std::invalid_argument("inverse filter: one weight per control point");
    for (std::size_t i = 0; i < p.control.size(); i++) {
        if (p.control[i] >= H.point_count())
            throw std::invalid_argument("inverse filter: control point not in the transfer matrix");
        points.push_back(p.control[i]);
        weights.push_back(p.control_weights.empty() ? 1.0 : p.control_weights[i]);
    }
    Eigen::MatrixXd G = normal_matrix(summed_correlations(plates, points, weights, J), C, J);
    return solve_design(G, focus_rhs(plates, p, o), penalty_lags(o, H.rate_hz, J), o.regularization, C, J, H.rate_hz);
}

std::vector<std::size_t> control_points(const CalibrationInput &in, const TransferMatrix &H, std::size_t f)
{
    return control_points(in, H, std::vector<std::size_t>{f});
}

std::vector<std::size_t> control_points(const CalibrationInput &in, const TransferMatrix &H,
                                        const std::vector<std::size_t> &set)
{
    const double lambda_half = judged_lambda_half_m(in);
    auto far = [&](Point p) {
        for (std::size_t f : set) {
            const Point at = in.foci.points[f].at;
            if (!(dist(p, at) > lambda_half))
                return false;
        }
        return true;
    };
    std::vector<std::size_t> q;
    for (std::size_t n : lattice_in_area(in, H.lattice))
        if (far(H.lattice.at(n)))
            q.push_back(n);
    for (std::size_t g = 0; g < in.foci.points.size(); g++)
        if (std::find(set.begin(), set.end(), g) == set.end() && H.exact_begin() + g < H.point_count() &&
            far(in.foci.points[g].at))
            q.push_back(H.exact_begin() + g);
    return q;
}

std::vector<double> focus_target(const CalibrationInput &in, double rate_hz, double centre_s)
{
    const std::vector<double> pulse = sample_pulse(in.pulse, rate_hz);
    const long start = std::lround((centre_s - pulse_duration_s(in.pulse) / 2) * rate_hz);
    std::vector<double> d(std::size_t(std::max(0L, start)) + pulse.size(), 0.0);
    for (std::size_t i = 0; i < pulse.size(); i++)
        if (start + long(i) >= 0)
            d[std::size_t(start + long(i))] = pulse[i];
    return d;
}

InverseFilterDesign minimax_design(const TransferMatrix &H, InverseFilterProblem p, const InverseFilterOptions &o)
{
    return minimax_design(Plates{&H}, std::move(p), o);
}

InverseFilterDesign minimax_design(const Plates &plates, InverseFilterProblem p, const InverseFilterOptions &o)
{
    if (o.minimax_iterations <= 0 || p.control.empty())
        return design_inverse_filter(plates, p, o);
    check_plates(plates);
    std::vector<std::size_t> served = p.control;
    served.insert(served.end(), p.foci.begin(), p.foci.end());
    std::vector<std::unique_ptr<Playback>> pb;
    for (const TransferMatrix *Hm : plates)
        pb.push_back(std::make_unique<Playback>(*Hm, served, p.drive_samples, p.drive_samples + Hm->samples - 1));
    return lawson(
        p.control.size(), o.minimax_iterations, p.control_weights,
        [&](const std::vector<double> &) { return design_inverse_filter(plates, p, o); },
        [&](const std::vector<std::vector<double>> &drive) {
            std::vector<std::vector<std::vector<float>>> w;
            for (const auto &play : pb)
                w.push_back(play->field(drive));
            return w;
        });
}

std::vector<DriveSignals> inverse_filter_signals(const CalibrationInput &in, const TransferMatrix &H,
                                                 const ProgressFn &progress)
{
    return inverse_filter_signals(in, Plates{&H}, progress);
}

} // namespace calib::pipeline
