#include "pipeline/design/inverse_filter.h"

#include "pipeline/data/lead_time.h"
#include "pipeline/design/block_toeplitz.h"
#include "pipeline/design/finishing.h"
#include "pipeline/signal/peaks.h"
#include "pipeline/signal/pulse.h"
#include "pipeline/signal/real_fft.h"
#include "pipeline/transfer/playback.h"

#include <Eigen/Dense>
#include <Spectra/MatOp/DenseSymMatProd.h>
#include <Spectra/SymEigsSolver.h>
#include <unsupported/Eigen/FFT>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>

#include <omp.h>

namespace calib::pipeline {

namespace {

using Complex = std::complex<double>;

std::size_t next_pow2(std::size_t n)
{
    std::size_t m = 1;
    while (m < n)
        m *= 2;
    return m;
}

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

// The same design from R (summed_correlations) without forming G: lambda_max
// and the solve through ToeplitzOperator and BlockLevinson, G formed and
// factored only where those do not get there (then as solve_design).
InverseFilterDesign toeplitz_design(const Eigen::VectorXd &R, const Eigen::VectorXd &b, const std::vector<double> &pen,
                                    double regularization, std::size_t C, std::size_t J, double rate_hz, RealFft &fft,
                                    BlockLevinson &lev)
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

} // namespace

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
    const Rect &a = in.active.area;
    auto far = [&](Point p) {
        for (std::size_t f : set) {
            const Point at = in.foci.points[f].at;
            if (!(dist(p, at) > lambda_half))
                return false;
        }
        return true;
    };
    std::vector<std::size_t> q;
    for (std::size_t n = 0; n < H.lattice.size(); n++) {
        const Point p = H.lattice.at(n);
        if (a.contains(p) && far(p))
            q.push_back(n);
    }
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

namespace {

// The joint design's index for its dither seed: one no focus has.
constexpr uint64_t joint_drive = 999983;

// The scene's drive length J at H's rate: its lead time, and its active
// damping after the focal instant.
std::size_t scene_drive_samples(const CalibrationInput &in, double rate_hz)
{
    return static_cast<std::size_t>(
               std::floor((target_lead_time_s(in) + in.calibration.active_damping_s) * rate_hz + 1e-9)) +
           1;
}
std::size_t scene_drive_samples(const CalibrationInput &in, const TransferMatrix &H)
{
    return scene_drive_samples(in, H.rate_hz);
}

// The scene's problem of the foci `set` (indices into the scene's foci) on H.
InverseFilterProblem scene_problem(const CalibrationInput &in, const TransferMatrix &H,
                                   const std::vector<std::size_t> &set)
{
    InverseFilterProblem p;
    p.drive_samples = scene_drive_samples(in, H);
    p.target = focus_target(in, H.rate_hz, focus_centre_s(in));
    for (std::size_t f : set)
        p.foci.push_back(H.exact_begin() + f);
    p.control = control_points(in, H, set);
    return p;
}

// Every point a scene's design can weigh: the lattice points in the active
// area and the foci (control_points draws from these).
std::vector<std::size_t> scene_points(const CalibrationInput &in, const TransferMatrix &H)
{
    const Rect &a = in.active.area;
    std::vector<std::size_t> q;
    for (std::size_t n = 0; n < H.lattice.size(); n++) {
        if (a.contains(H.lattice.at(n)))
            q.push_back(n);
    }
    for (std::size_t g = 0; g < in.foci.points.size(); g++)
        if (H.exact_begin() + g < H.point_count())
            q.push_back(H.exact_begin() + g);
    return q;
}

// What the designs of all foci share. A focus's normal matrix is
//   sum_{p in Q_f} w_p G_p + W_f G_f,
// G_p the block Toeplitz matrix of point p's cross-correlations, which does
// not depend on the focus nor on the weights: so each point's correlations
// (summed over the plates) are computed once, and a design's R (see
// summed_correlations) is their weighted sum, R = Rp w, w zero at the points
// the focus does not weigh. Likewise one playback serves every focus's
// minimax refinement, and each design is solved without forming G
// (toeplitz_design). The designs are those of minimax_design to round-off
// (the sums taken in another order, another backward-stable solve);
// test_inverse_filter_shared checks it.
class SharedDesigns {
  public:
    SharedDesigns(const Plates &plates, const std::vector<std::size_t> &points, std::size_t drive_samples);
    // minimax_design(plates, p, o), p's points among those served.
    InverseFilterDesign minimax(InverseFilterProblem p, const InverseFilterOptions &o) const;

  private:
    Eigen::Index column(std::size_t point) const;

    const Plates &plates_;
    std::size_t J_;
    std::vector<std::ptrdiff_t> column_;          // per point of H, its column of Rp (-1: not served)
    Eigen::MatrixXd Rp_;                          // [pair, lag][point], as R with that point alone at weight 1
    std::vector<std::unique_ptr<Playback>> play_; // per plate, the served points
};

SharedDesigns::SharedDesigns(const Plates &plates, const std::vector<std::size_t> &points, std::size_t J)
    : plates_(plates), J_(J), column_(plates.front()->point_count(), -1)
{
    const TransferMatrix &H = *plates.front();
    const std::size_t C = H.channels, S = H.samples, N = next_pow2(S + J - 1), L = lag_count(J), P = points.size();
    const std::size_t pairs = C * (C + 1) / 2, bins = N / 2 + 1;
    for (std::size_t i = 0; i < P; i++)
        column_[points[i]] = std::ptrdiff_t(i);
    Rp_.resize(Eigen::Index(pairs * L), Eigen::Index(P));
    std::string failure;
#pragma omp parallel
    {
        const std::unique_ptr<RealFft> fft = thread_fft(N, failure);
        std::vector<Complex> X(C * bins), cross(pairs * bins);
#pragma omp for schedule(dynamic, 8)
        for (std::size_t i = 0; i < P; i++) {
            if (!fft)
                continue;
            std::fill(cross.begin(), cross.end(), Complex{});
            for (const TransferMatrix *Hm : plates) {
                for (std::size_t c = 0; c < C; c++) {
                    fft->forward_padded(Hm->response(c, points[i]), S);
                    std::copy(fft->spectrum(), fft->spectrum() + bins, X.begin() + long(c * bins));
                }
                std::size_t k = 0;
                for (std::size_t c = 0; c < C; c++)
                    for (std::size_t d = c; d < C; d++, k++)
                        for (std::size_t b = 0; b < bins; b++)
                            cross[k * bins + b] += std::conj(X[c * bins + b]) * X[d * bins + b];
            }
            for (std::size_t k = 0; k < pairs; k++) {
                std::copy(cross.begin() + long(k * bins), cross.begin() + long((k + 1) * bins), fft->spectrum());
                fft->inverse();
                for (std::size_t l = 0; l < L; l++) {
                    const long lag = long(l) - long(J - 1);
                    Rp_(Eigen::Index(k * L + l), Eigen::Index(i)) =
                        fft->real()[std::size_t((lag + long(N)) % long(N))] / double(N);
                }
            }
        }
    }
    if (!failure.empty())
        throw std::runtime_error("inverse filter: " + failure);
    for (const TransferMatrix *Hm : plates)
        play_.push_back(std::make_unique<Playback>(*Hm, points, J, J + Hm->samples - 1));
}

Eigen::Index SharedDesigns::column(std::size_t point) const
{
    if (point >= column_.size() || column_[point] < 0)
        throw std::invalid_argument("inverse filter: point " + std::to_string(point) + " not among those served");
    return Eigen::Index(column_[point]);
}

InverseFilterDesign SharedDesigns::minimax(InverseFilterProblem p, const InverseFilterOptions &o) const
{
    const TransferMatrix &H = *plates_.front();
    const std::size_t C = H.channels, J = J_;
    if (p.drive_samples != J || p.target.empty() || p.foci.empty())
        throw std::invalid_argument("inverse filter: empty problem or another drive length than the one shared");
    if (!(o.regularization >= 0) || !(o.focus_weight > 0))
        throw std::invalid_argument("inverse filter: regularization must be >= 0 and the focus weight > 0");
    if (!p.control_weights.empty() && p.control_weights.size() != p.control.size())
        throw std::invalid_argument("inverse filter: one weight per control point");
    std::vector<std::size_t> which; // the control points then the foci, as columns
    for (std::size_t q : p.control)
        which.push_back(std::size_t(column(q)));
    for (std::size_t f : p.foci)
        which.push_back(std::size_t(column(f)));
    const std::size_t Q = p.control.size();
    const Eigen::VectorXd b = focus_rhs(plates_, p, o);
    const std::vector<double> pen = penalty_lags(o, H.rate_hz, J);
    RealFft fft(fft_friendly_size(3 * J - 2));
    BlockLevinson lev(C, J);
    auto design = [&](const std::vector<double> &weights) {
        Eigen::VectorXd w = Eigen::VectorXd::Zero(Rp_.cols());
        for (std::size_t i = Q; i < which.size(); i++)
            w(Eigen::Index(which[i])) += o.focus_weight;
        for (std::size_t i = 0; i < Q; i++)
            w(Eigen::Index(which[i])) += weights.empty() ? 1.0 : weights[i];
        return toeplitz_design(Rp_ * w, b, pen, o.regularization, C, J, H.rate_hz, fft, lev);
    };
    if (o.minimax_iterations <= 0 || p.control.empty())
        return design(p.control_weights);
    return lawson(Q, o.minimax_iterations, p.control_weights, design, [&](const std::vector<std::vector<double>> &d) {
        std::vector<std::vector<std::vector<float>>> w;
        for (const auto &play : play_)
            w.push_back(play->field(d, which));
        return w;
    });
}

// The scene's designs of `sets` (each a set of indices into the scene's
// foci) over `plates`. Shared: through SharedDesigns, the sets in parallel
// (Eigen then runs each design on one thread: the same arithmetic whichever
// sets are asked, so a set's design does not depend on the others);
// otherwise each from scratch (minimax_design). A failure names the set.
std::vector<InverseFilterDesign> scene_designs(const CalibrationInput &in, const Plates &plates,
                                               const std::vector<std::vector<std::size_t>> &sets,
                                               const std::vector<std::string> &names, bool shared,
                                               const ProgressFn &progress)
{
    check_plates(plates);
    const TransferMatrix &H = *plates.front();
    std::vector<InverseFilterDesign> out(sets.size());
    if (sets.empty())
        return out;
    std::unique_ptr<SharedDesigns> common;
    if (shared)
        common = std::make_unique<SharedDesigns>(plates, scene_points(in, H), scene_drive_samples(in, H));
    const InverseFilterOptions o = scene_inverse_filter_options(in);
    std::size_t done = 0;
    std::string failure;
    if (progress)
        progress("signals", 0, sets.size());
#pragma omp parallel for schedule(dynamic, 1) if (shared)
    for (std::size_t i = 0; i < sets.size(); i++) {
        try {
            InverseFilterProblem p = scene_problem(in, H, sets[i]);
            out[i] = common ? common->minimax(std::move(p), o) : minimax_design(plates, std::move(p), o);
        } catch (const std::exception &e) {
#pragma omp critical(inverse_filter_failure)
            if (failure.empty())
                failure = names[i] + ": " + e.what();
        }
#pragma omp critical(inverse_filter_progress)
        {
            done++;
            if (progress)
                progress("signals", done, sets.size());
        }
    }
    if (!failure.empty())
        throw std::runtime_error(failure);
    return out;
}

// The drive of a scene's design at full scale, finished with the scene's
// options for drive `drive` (finishing.h drive_options).
DriveSignals scene_signals(const CalibrationInput &in, const TransferMatrix &H, InverseFilterDesign d, uint64_t drive)
{
    // The focus instant from playback start, on H's sample grid (focus_target).
    const double delay =
        double(std::lround((focus_centre_s(in) - pulse_duration_s(in.pulse) / 2) * H.rate_hz)) / H.rate_hz +
        pulse_duration_s(in.pulse) / 2;
    return finish_drive_signals(std::move(d.drive), H.rate_hz, delay, drive_options(in, drive));
}

} // namespace

std::vector<InverseFilterDesign> inverse_filter_designs(const CalibrationInput &in, const Plates &plates,
                                                        const ProgressFn &progress, bool shared)
{
    std::vector<std::vector<std::size_t>> sets;
    std::vector<std::string> names;
    for (std::size_t f = 0; f < in.foci.points.size(); f++) {
        sets.push_back({f});
        names.push_back("focus " + std::to_string(in.foci.points[f].id));
    }
    return scene_designs(in, plates, sets, names, shared, progress);
}

std::vector<DriveSignals> inverse_filter_signals(const CalibrationInput &in, const Plates &plates,
                                                 const ProgressFn &progress)
{
    std::vector<InverseFilterDesign> designs = inverse_filter_designs(in, plates, progress);
    std::vector<DriveSignals> out(designs.size());
    std::string failure;
#pragma omp parallel for schedule(dynamic, 1)
    for (std::size_t f = 0; f < designs.size(); f++) {
        try {
            out[f] = scene_signals(in, *plates.front(), std::move(designs[f]), f);
        } catch (const std::exception &e) {
#pragma omp critical(inverse_filter_failure)
            if (failure.empty())
                failure = "focus " + std::to_string(in.foci.points[f].id) + ": " + e.what();
        }
    }
    if (!failure.empty())
        throw std::runtime_error(failure);
    return out;
}

DriveSignals joint_inverse_filter_signals(const CalibrationInput &in, const TransferMatrix &H,
                                          const std::vector<std::size_t> &set)
{
    std::string ids;
    for (std::size_t f : set)
        ids += (ids.empty() ? "" : "+") + std::to_string(in.foci.points.at(f).id);
    InverseFilterDesign design = scene_designs(in, Plates{&H}, {set}, {"foci " + ids}, true, {}).front();
    try {
        DriveSignals d = scene_signals(in, H, std::move(design), joint_drive);
        if (in.effects.exciter && in.effects.exciter->precompensate) // as the table's drives
            precompensate_for_exciter(d, *in.effects.exciter, drive_options(in, joint_drive));
        return d;
    } catch (const std::exception &e) {
        throw std::runtime_error("foci " + ids + ": " + e.what());
    }
}

InverseFilterOptions scene_inverse_filter_options(const CalibrationInput &in)
{
    InverseFilterOptions o;
    o.regularization = in.calibration.regularization;
    o.band_edge_hz = pulse_max_frequency_hz(in.pulse);
    return o;
}

InverseFilterShape inverse_filter_shape(const CalibrationInput &in, double rate_hz, std::size_t samples,
                                        std::size_t lattice_in_area)
{
    InverseFilterShape s;
    s.channels = in.exciters.count;
    s.samples = samples;
    s.rate_hz = rate_hz;
    s.drive_samples = scene_drive_samples(in, rate_hz);
    s.points = lattice_in_area + in.foci.points.size();
    if (in.robust)
        s.plates += in.robust->loss.size() + in.robust->youngs_scale.size();
    return s;
}

double inverse_filter_bytes(const InverseFilterShape &s, std::size_t running)
{
    const double C = double(s.channels), J = double(s.drive_samples), P = double(s.points);
    const double bins = double(fft_friendly_size(std::max<std::size_t>(2, s.drive_samples + s.samples)) / 2 + 1);
    const double shared = C * (C + 1) / 2 * double(lag_count(s.drive_samples)) * P * 8      // Rp
                          + double(s.plates) * P * C * bins * 8;                            // playback spectra
    const double design = (C * J) * (C * J) * 8                                             // block Levinson's U
                          + double(s.plates) * P * double(s.drive_samples + s.samples) * 4; // fields
    return shared + double(running) * design;
}

InverseFilterSeconds time_inverse_filter(const InverseFilterShape &s, const InverseFilterOptions &o)
{
    using Clock = std::chrono::steady_clock;
    if (s.channels == 0 || s.samples == 0 || s.drive_samples == 0 || !(s.rate_hz > 0))
        throw std::invalid_argument("inverse filter: an empty shape to time");
    // Timed on at most 16 exciters, C J <= 4096 (block Levinson's factor
    // 128 MB) and a random H of at most 64 MB, then scaled as the work grows:
    // C^3 J^2 for block Levinson, the rest within it. A scene that large
    // is priced, not run (its memory refuses it).
    const std::size_t C = std::min<std::size_t>(s.channels, 16);
    const std::size_t J = std::min(s.drive_samples, std::max<std::size_t>(1, 4096 / C));
    const std::size_t S = std::min(s.samples, std::max<std::size_t>(1, (std::size_t(1) << 24) / (64 * C)));
    const double scale = std::pow(double(s.channels) / double(C), 3) *
                         std::pow(double(s.drive_samples) / double(J), 2) *
                         std::max(1.0, double(s.samples) / double(S));
    InverseFilterOptions one_pass = o;
    one_pass.minimax_iterations = std::min(o.minimax_iterations, 1);
    const double passes = double(std::max(o.minimax_iterations, 0) + 1);
    // Random decaying responses (a fixed LCG: the same every run).
    auto timed = [&](std::size_t points) {
        TransferMatrix H;
        H.channels = C;
        H.samples = S;
        H.rate_hz = s.rate_hz;
        H.lattice.cols = int(points);
        H.lattice.rows = 1;
        H.points.resize(points);
        H.data.resize(C * points * S);
        uint64_t x = 88172645463325252ull;
        for (std::size_t i = 0; i < H.data.size(); i++) {
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            const double u = double(x >> 11) * 0x1.0p-53 - 0.5;
            H.data[i] = float(u * std::exp(-4.0 * double(i % S) / double(S)));
        }
        InverseFilterProblem p;
        p.drive_samples = J;
        p.foci = {0};
        for (std::size_t q = 1; q < points; q++)
            p.control.push_back(q);
        // Two cycles under a Hann window, centred near the end of the drive.
        const std::size_t start = J > 8 ? J - 8 : 0;
        p.target.assign(start + 16, 0.0);
        for (std::size_t n = 0; n < 16; n++)
            p.target[start + n] = std::sin(std::numbers::pi * double(n) / 4) *
                                  (0.5 - 0.5 * std::cos(2 * std::numbers::pi * double(n) / 16));
        std::vector<std::size_t> all(points);
        for (std::size_t q = 0; q < points; q++)
            all[q] = q;
        const Plates plates(s.plates, &H);
        // The fastest of three (a shared machine only slows a run down), one
        // minimax pass after the first design: a pass costs the same each time.
        double shared_s = INFINITY, design_s = INFINITY;
        for (int r = 0; r < 3; r++) {
            const auto t0 = Clock::now();
            const SharedDesigns shared(plates, all, J);
            const auto t1 = Clock::now();
            (void)shared.minimax(p, one_pass);
            const auto t2 = Clock::now();
            shared_s = std::min(shared_s, std::chrono::duration<double>(t1 - t0).count());
            design_s = std::min(design_s, std::chrono::duration<double>(t2 - t1).count());
        }
        return std::pair{shared_s, design_s * passes / double(one_pass.minimax_iterations + 1)};
    };
    const std::size_t p1 = 8, p2 = 64;
    InverseFilterSeconds out;
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    try {
        const auto [s1, d1] = timed(p1);
        const auto [s2, d2] = timed(p2);
        omp_set_num_threads(threads);
        auto at = [&](double a, double b) {
            const double slope = std::max(0.0, (b - a) / double(p2 - p1));
            return std::max(a, b) + slope * std::max(0.0, double(s.points) - double(p2));
        };
        out.shared_s = at(s1, s2) * scale;
        out.per_focus_s = at(d1, d2) * scale;
    } catch (...) {
        omp_set_num_threads(threads);
        throw;
    }
    return out;
}

} // namespace calib::pipeline
