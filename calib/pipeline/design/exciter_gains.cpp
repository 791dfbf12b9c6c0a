#include "pipeline/design/exciter_gains.h"

#include <algorithm>
#include <cmath>

namespace calib::pipeline {

namespace {

// |G_i . w| for every column.
Eigen::VectorXf residuals(const Eigen::MatrixXf &G, const Eigen::VectorXd &w)
{
    const Eigen::VectorXf wf = w.cast<float>();
    return (wf.transpose() * G).cwiseAbs().transpose();
}

// Lawson's iterations on the columns `rows` of G: the gains with a . w =
// focal whose largest residual over those columns is least among the
// iterates (the first iterate is the unweighted least-squares solution).
Eigen::VectorXd lawson(const Eigen::MatrixXf &G, const Eigen::VectorXd &a, double focal, std::vector<Eigen::Index> rows,
                       unsigned iterations)
{
    const Eigen::Index C = a.size();
    std::vector<double> q(rows.size(), 1.0 / double(rows.size()));
    Eigen::VectorXd best;
    double best_max = INFINITY;
    for (unsigned it = 0; it < iterations && !rows.empty(); it++) {
        // A = sum_k q_k g_k g_k^T (lower triangle, then mirrored).
        Eigen::MatrixXd A = Eigen::MatrixXd::Zero(C, C);
        for (std::size_t k = 0; k < rows.size(); k++) {
            const float *g = G.data() + rows[k] * C;
            for (Eigen::Index c = 0; c < C; c++) {
                const double qg = q[k] * double(g[c]);
                double *col = A.data() + c * C; // column c, rows c..C-1
                for (Eigen::Index d = c; d < C; d++)
                    col[d] += qg * double(g[d]);
            }
        }
        const Eigen::MatrixXd full = A.selfadjointView<Eigen::Lower>();
        A = full;
        A.diagonal().array() += 1e-12 * A.trace() / double(C);
        Eigen::VectorXd w = A.ldlt().solve(a);
        const double at = a.dot(w);
        if (!std::isfinite(at) || at == 0)
            break;
        w *= focal / at;
        const Eigen::VectorXf wf = w.cast<float>();
        double sum = 0, top = 0, worst = 0;
        for (std::size_t k = 0; k < rows.size(); k++) {
            const float *g = G.data() + rows[k] * C;
            float dot = 0;
            for (Eigen::Index c = 0; c < C; c++)
                dot += g[c] * wf[c];
            const double r = std::abs(double(dot));
            worst = std::max(worst, r);
            sum += q[k] *= r;
        }
        if (worst < best_max) {
            best_max = worst;
            best = w;
        }
        if (!(sum > 0))
            break;
        for (double &v : q)
            top = std::max(top, v /= sum);
        // Rows whose weight has vanished take no further part.
        std::size_t kept = 0;
        for (std::size_t k = 0; k < rows.size(); k++)
            if (q[k] >= 1e-9 * top) {
                rows[kept] = rows[k];
                q[kept++] = q[k];
            }
        rows.resize(kept);
        q.resize(kept);
    }
    return best;
}

} // namespace

ExciterGains minimax_gains(const Eigen::MatrixXf &G, const Eigen::VectorXd &a, unsigned iterations)
{
    const Eigen::Index C = a.size(), N = G.cols();
    ExciterGains out;
    out.gain.assign(std::size_t(C), 1.0);
    const double focal = a.sum();
    if (C == 0 || N == 0 || G.rows() != C || !std::isfinite(focal) || focal == 0)
        return out;
    Eigen::VectorXd best = Eigen::VectorXd::Ones(C);
    Eigen::VectorXf r = residuals(G, best);
    double best_max = r.maxCoeff();
    out.equal_ratio = best_max / std::abs(focal);

    // An active set: Lawson on the rows near the largest residual, then the
    // rows the result lets rise near its own largest added, until none does.
    // Most of a focus's rows (its points and times) stay far below the
    // largest whatever the gains, and never enter.
    std::vector<char> in(static_cast<std::size_t>(N), 0);
    std::vector<Eigen::Index> rows;
    auto admit = [&](double floor) {
        std::size_t added = 0;
        for (Eigen::Index i = 0; i < N; i++)
            if (!in[std::size_t(i)] && r[i] >= floor) {
                in[std::size_t(i)] = 1;
                rows.push_back(i);
                added++;
            }
        return added;
    };
    admit(0.5 * best_max);
    for (int round = 0; round < 8; round++) {
        const Eigen::VectorXd w = lawson(G, a, focal, rows, iterations);
        if (w.size() != C)
            break;
        r = residuals(G, w);
        const double m = r.maxCoeff();
        if (m < best_max) {
            best_max = m;
            best = w;
        }
        if (admit(0.8 * m) == 0)
            break;
    }
    for (Eigen::Index c = 0; c < C; c++)
        out.gain[std::size_t(c)] = best[c];
    out.ratio = best_max / std::abs(focal);
    return out;
}

} // namespace calib::pipeline
