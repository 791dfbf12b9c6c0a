#include "pipeline/inverse_filter.h"

#include "pipeline/calibrate.h"
#include "pipeline/calibrate_stages.h"
#include "pipeline/lead_time.h"
#include "pipeline/peaks.h"
#include "pipeline/playback.h"
#include "pipeline/pulse.h"

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

namespace {

using Complex = std::complex<double>;

std::size_t next_pow2(std::size_t n)
{
    std::size_t m = 1;
    while (m < n)
        m *= 2;
    return m;
}

// Largest eigenvalue of a symmetric positive semi-definite matrix (Lanczos).
double largest_eigenvalue(const Eigen::MatrixXd &G)
{
    const Eigen::Index n = G.rows();
    if (n <= 8) {
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(G, Eigen::EigenvaluesOnly);
        return es.eigenvalues().maxCoeff();
    }
    Spectra::DenseSymMatProd<double> op(G);
    Spectra::SymEigsSolver<Spectra::DenseSymMatProd<double>> eigs(op, 1, std::min<Eigen::Index>(n, 20));
    eigs.init();
    eigs.compute(Spectra::SortRule::LargestAlge, 1000, 1e-8);
    if (eigs.info() != Spectra::CompInfo::Successful)
        throw std::runtime_error("inverse filter: the largest eigenvalue of H^T H did not converge");
    return eigs.eigenvalues()[0];
}

// Cross-correlations summed over plates and points with weights:
//   R[c][c'][l + J - 1] = sum_m sum_p w_p sum_n h^m_cp[n] h^m_c'p[n + l],  |l| < J,
// from the cross-spectra of the zero-padded responses (N >= S + J - 1: no
// wrap-around within the lags kept).
std::vector<std::vector<std::vector<double>>> summed_correlations(const Plates &plates,
                                                                  const std::vector<std::size_t> &points,
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
    std::vector<std::vector<std::vector<double>>> R(C, std::vector<std::vector<double>>(C));
    Eigen::FFT<double> fft;
    std::vector<double> out(N);
    std::vector<Complex> spec(N);
    std::size_t k = 0;
    for (std::size_t c = 0; c < C; c++)
        for (std::size_t d = c; d < C; d++, k++) {
            std::copy(total.begin() + long(k * N), total.begin() + long((k + 1) * N), spec.begin());
            fft.inv(out, spec);
            std::vector<double> &r = R[c][d];
            r.resize(2 * J - 1);
            for (std::size_t l = 0; l < 2 * J - 1; l++) {
                const long lag = long(l) - long(J - 1);
                r[l] = out[std::size_t((lag + long(N)) % long(N))];
            }
        }
    return R;
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

}  // namespace

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
    const std::size_t n = C * J;

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
    const auto R = summed_correlations(plates, points, weights, J);
    Eigen::MatrixXd G(n, n);
    for (std::size_t c = 0; c < C; c++)
        for (std::size_t d = c; d < C; d++)
            for (std::size_t j = 0; j < J; j++)
                for (std::size_t jj = 0; jj < J; jj++) {
                    // G[(c,j),(d,jj)] = sum_m h_c[m] h_d[m + j - jj]
                    const double v = R[c][d][j + J - 1 - jj];
                    G(Eigen::Index(c * J + j), Eigen::Index(d * J + jj)) = v;
                    G(Eigen::Index(d * J + jj), Eigen::Index(c * J + j)) = v;
                }

    // Right-hand side: W_f A_f^T d summed over the plates and the foci,
    // b[(c,j)] = W_f sum_m sum_f sum_n h^m_cf[n] d[n + j].
    Eigen::VectorXd b = Eigen::VectorXd::Zero(Eigen::Index(n));
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

    InverseFilterDesign out;
    out.lambda_max = largest_eigenvalue(G);
    out.beta = o.regularization * out.lambda_max;
    Eigen::VectorXd x;
    if (out.beta > 0) {
        // beta (I + rho P_out) per channel, P_out[l] = delta_l - 2 nu sinc(2 nu l):
        // the drive's energy above nu = band_edge / R cycles per sample.
        const double nu = o.band_edge_hz > 0 ? std::min(0.5, o.band_edge_hz / H.rate_hz) : 0.5;
        const double rho = o.band_edge_hz > 0 ? o.out_of_band_weight : 0.0;
        for (std::size_t j = 0; j < J; j++)
            for (std::size_t jj = 0; jj < J; jj++) {
                const double l = double(j) - double(jj);
                const double x2 = 2 * nu * l;
                const double sinc = l == 0 ? 1.0 : std::sin(std::numbers::pi * x2) / (std::numbers::pi * x2);
                const double pen = out.beta * ((j == jj ? 1.0 : 0.0) + rho * ((j == jj ? 1.0 : 0.0) - 2 * nu * sinc));
                for (std::size_t c = 0; c < C; c++)
                    G(Eigen::Index(c * J + j), Eigen::Index(c * J + jj)) += pen;
            }
        Eigen::LLT<Eigen::MatrixXd> llt(G);
        if (llt.info() == Eigen::Success)
            x = llt.solve(b);
        else
            x = G.ldlt().solve(b);
    } else {
        // Unregularised: the minimum-norm least-squares solution.
        x = G.completeOrthogonalDecomposition().solve(b);
    }
    if (!x.allFinite())
        throw std::runtime_error("inverse filter: the solve gave non-finite drives");
    out.drive.assign(C, std::vector<double>(J));
    for (std::size_t c = 0; c < C; c++)
        for (std::size_t j = 0; j < J; j++)
            out.drive[c][j] = x(Eigen::Index(c * J + j)) * H.rate_hz;  // w = (1/R) h * s
    return out;
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
            if (!(std::hypot(p.x_m - at.x_m, p.y_m - at.y_m) > lambda_half))
                return false;
        }
        return true;
    };
    std::vector<std::size_t> q;
    for (std::size_t n = 0; n < H.lattice.size(); n++) {
        const Point p = H.lattice.at(n);
        if (p.x_m >= a.x0_m && p.x_m <= a.x1_m && p.y_m >= a.y0_m && p.y_m <= a.y1_m && far(p))
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
    const std::size_t Q = p.control.size();
    std::vector<std::unique_ptr<Playback>> pb;
    for (const TransferMatrix *Hm : plates)
        pb.push_back(std::make_unique<Playback>(*Hm, served, p.drive_samples, p.drive_samples + Hm->samples - 1));
    p.control_weights.assign(Q, 1.0);
    InverseFilterDesign best;
    double best_ratio = -1;
    for (int it = 0; it <= o.minimax_iterations; it++) {
        InverseFilterDesign d = design_inverse_filter(plates, p, o);
        // Per control point its largest |w| over time relative to its plate's
        // focal peak (the weakest focus's), the largest over the plates (what
        // the worst plate's contrast sees; a plate that is louder overall does
        // not count as worse). One plate: |w| itself (the same weights, bit
        // for bit).
        std::vector<double> m(Q, 0.0);
        double worst = 0, focal = 1;
        for (const auto &play : pb) {
            const auto w = play->field(d.drive);
            focal = INFINITY;
            for (std::size_t i = Q; i < w.size(); i++)
                focal = std::min(focal, sample_peak(w[i].data(), w[i].size()));
            const double scale = pb.size() > 1 ? 1 / std::max(focal, 1e-300) : 1.0;
            for (std::size_t q = 0; q < Q; q++)
                m[q] = std::max(m[q], sample_peak(w[q].data(), w[q].size()) * scale);
        }
        for (std::size_t q = 0; q < Q; q++)
            worst = std::max(worst, m[q]);
        // The focal peak over the worst control point (of the worst plate).
        const double ratio = (pb.size() > 1 ? 1.0 : focal) / std::max(worst, 1e-300);
        if (ratio > best_ratio) {
            best_ratio = ratio;
            best = std::move(d);
        }
        if (!(worst > 0))
            break;
        double sum = 0;
        for (std::size_t q = 0; q < Q; q++)
            sum += (p.control_weights[q] *= m[q] / worst);
        for (double &v : p.control_weights)
            v *= double(Q) / sum;
    }
    return best;
}

std::vector<DriveSignals> inverse_filter_signals(const CalibrationInput &in, const TransferMatrix &H)
{
    return inverse_filter_signals(in, Plates{&H});
}

namespace {

// The device-side finishing of a drive: the output rate and dither of the scene.
TimeReversalOptions finishing(const CalibrationInput &in, uint64_t dither_seed)
{
    TimeReversalOptions tro;
    tro.output_rate_hz = in.calibration.output_rate_hz;
    tro.dither = in.calibration.dither;
    tro.dither_seed = dither_seed;
    return tro;
}

// The scene's design of the foci `set` (indices into the scene's foci) over
// `plates`, at full scale.
DriveSignals scene_design(const CalibrationInput &in, const Plates &plates, const std::vector<std::size_t> &set,
                          uint64_t dither_seed)
{
    const TransferMatrix &H = *plates.front();
    const TimeReversalOptions tro = finishing(in, dither_seed);
    InverseFilterOptions o;
    o.regularization = in.calibration.regularization;
    o.band_edge_hz = pulse_max_frequency_hz(in.pulse);
    const double lead = target_lead_time_s(in), centre = focus_centre_s(in);
    InverseFilterProblem p;
    p.drive_samples = static_cast<std::size_t>(std::floor(lead * H.rate_hz + 1e-9)) + 1;
    p.target = focus_target(in, H.rate_hz, centre);
    const double delay = double(std::lround((centre - pulse_duration_s(in.pulse) / 2) * H.rate_hz)) / H.rate_hz +
                         pulse_duration_s(in.pulse) / 2;
    for (std::size_t f : set)
        p.foci.push_back(H.exact_begin() + f);
    p.control = control_points(in, H, set);
    InverseFilterDesign d = minimax_design(plates, p, o);
    return finish_drive_signals(std::move(d.drive), H.rate_hz, delay, tro);
}

}  // namespace

std::vector<DriveSignals> inverse_filter_signals(const CalibrationInput &in, const Plates &plates)
{
    check_plates(plates);
    std::vector<DriveSignals> out;
    for (std::size_t f = 0; f < in.foci.points.size(); f++) {
        try {
            out.push_back(scene_design(in, plates, {f}, in.exciters.seed * 1000003u + f));
        } catch (const std::exception &e) {
            throw std::runtime_error("focus " + std::to_string(in.foci.points[f].id) + ": " + e.what());
        }
    }
    return out;
}

DriveSignals joint_inverse_filter_signals(const CalibrationInput &in, const TransferMatrix &H,
                                          const std::vector<std::size_t> &set)
{
    std::string ids;
    for (std::size_t f : set)
        ids += (ids.empty() ? "" : "+") + std::to_string(in.foci.points.at(f).id);
    try {
        const uint64_t seed = in.exciters.seed * 1000003u + 999983u;
        DriveSignals d = scene_design(in, Plates{&H}, set, seed);
        if (in.effects.exciter && in.effects.exciter->precompensate) {  // as the table's drives
            precompensate_for_exciter(d, *in.effects.exciter, finishing(in, seed));
        }
        return d;
    } catch (const std::exception &e) {
        throw std::runtime_error("foci " + ids + ": " + e.what());
    }
}

}  // namespace calib::pipeline
