#include "pipeline/design/shared_designs.h"

#include "pipeline/design/inverse_filter_solve.h"

#include <stdexcept>
#include <string>

namespace calib::pipeline {

using namespace inverse_solve;

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

} // namespace calib::pipeline
