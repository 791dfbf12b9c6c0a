#include "pipeline/design/block_toeplitz.h"

#include "pipeline/design/levinson_kernels.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace calib::pipeline {

using Complex = std::complex<double>;

ToeplitzOperator::ToeplitzOperator(const Eigen::VectorXd &R, std::size_t C, std::size_t J, RealFft &fft)
    : C_(C), J_(J), fft_(fft), a_(Eigen::Index(C * C), Eigen::Index(lag_count(J))),
      A_(Eigen::Index(C * C), Eigen::Index(fft.bins()))
{
    const std::size_t L = lag_count(J);
    std::size_t k = 0;
    for (std::size_t c = 0; c < C; c++)
        for (std::size_t d = c; d < C; d++, k++)
            for (std::size_t l = 0; l < L; l++) {
                a_(Eigen::Index(c * C + d), Eigen::Index(l)) = R(Eigen::Index(k * L + l));
                a_(Eigen::Index(d * C + c), Eigen::Index(L - 1 - l)) = R(Eigen::Index(k * L + l));
            }
    for (std::size_t cd = 0; cd < C * C; cd++)
        transform(cd);
}

void ToeplitzOperator::transform(std::size_t cd)
{
    fft_.forward_padded(a_.row(Eigen::Index(cd)).eval().data(), lag_count(J_));
    for (std::size_t b = 0; b < fft_.bins(); b++)
        A_(Eigen::Index(cd), Eigen::Index(b)) = fft_.spectrum()[b];
}

void ToeplitzOperator::regularise(double beta, const std::vector<double> &pen)
{
    for (std::size_t c = 0; c < C_; c++) {
        for (std::size_t l = 0; l < lag_count(J_); l++)
            a_(Eigen::Index(c * C_ + c), Eigen::Index(l)) += beta * pen[l];
        transform(c * C_ + c);
    }
}

void ToeplitzOperator::perform_op(const double *x, double *y) const
{
    // y_c[j] = sum_d (a_cd conv x_d)[j + J - 1]: a_cd from position 0 (lag
    // 1 - J), x_d from 0; the linear convolution's 3 J - 2 samples fit.
    const Eigen::Index bins = Eigen::Index(fft_.bins());
    Eigen::Matrix<Complex, Eigen::Dynamic, Eigen::Dynamic> X(bins, Eigen::Index(C_));
    for (std::size_t d = 0; d < C_; d++) {
        fft_.forward_padded(x + d * J_, J_);
        X.col(Eigen::Index(d)) = Eigen::Map<const Eigen::VectorXcd>(fft_.spectrum(), bins);
    }
    const double scale = 1.0 / double(fft_.size());
    for (std::size_t c = 0; c < C_; c++) {
        Eigen::Map<Eigen::VectorXcd> Y(fft_.spectrum(), bins);
        Y.setZero();
        for (std::size_t d = 0; d < C_; d++)
            Y += A_.row(Eigen::Index(c * C_ + d)).transpose().cwiseProduct(X.col(Eigen::Index(d)));
        fft_.inverse();
        for (std::size_t j = 0; j < J_; j++)
            y[c * J_ + j] = fft_.real()[j + J_ - 1] * scale;
    }
}

double ToeplitzOperator::norm_inf() const
{
    // Row (c, j) meets the lags j - J + 1 ... j of every a_cd: a window of J
    // over the prefix sums of |a_cd|.
    const std::size_t L = lag_count(J_);
    Eigen::MatrixXd sums = Eigen::MatrixXd::Zero(Eigen::Index(C_), Eigen::Index(L + 1));
    for (std::size_t c = 0; c < C_; c++)
        for (std::size_t d = 0; d < C_; d++) {
            double s = 0;
            for (std::size_t l = 0; l < L; l++) {
                s += std::abs(a_(Eigen::Index(c * C_ + d), Eigen::Index(l)));
                sums(Eigen::Index(c), Eigen::Index(l + 1)) += s;
            }
        }
    double top = 0;
    for (std::size_t c = 0; c < C_; c++)
        for (std::size_t j = 0; j < J_; j++)
            top = std::max(top, sums(Eigen::Index(c), Eigen::Index(j + J_)) - sums(Eigen::Index(c), Eigen::Index(j)));
    return top;
}

BlockLevinson::BlockLevinson(std::size_t C, std::size_t J)
    : C_(C), J_(J), U_(Eigen::Index(C * J), Eigen::Index(C * J)), row_(Eigen::Index(C), Eigen::Index(C * J)),
      top_(Eigen::Index(C), Eigen::Index(C * J)), F_(Eigen::Index(C * J), Eigen::Index(C)),
      B_(Eigen::Index(C * J), Eigen::Index(C)), f_(Eigen::Index(C * J), Eigen::Index(C))
{}

bool BlockLevinson::factor(const ToeplitzOperator &G)
{
    using Eigen::Index;
    const Index c = Index(C_), Jl = Index(J_);
    // [M_{J-1} ... M_1 M_0] and [M_0^T M_1^T ... M_{J-1}^T] side by side: the
    // block rows that meet F^k and B^k.
    for (Index k = 0; k < Jl; k++)
        for (Index a = 0; a < c; a++)
            for (Index d = 0; d < c; d++) {
                const double m = G.lag(std::size_t(a), std::size_t(d), long(k));
                row_(a, (Jl - 1 - k) * c + d) = m;
                top_(d, k * c + a) = m;
            }
    // F^k in the top rows of F_, B^k in the bottom rows of B_ (so [0; B^k]
    // is B^k where it is).
    const Index n = c * Jl;
    F_.setZero();
    B_.setZero();
    F_.topRows(c).setIdentity();
    B_.bottomRows(c).setIdentity();
    Eigen::MatrixXd Ef = row_.rightCols(c), Eb = Ef;
    E_.clear();
    E_.emplace_back(Eb);
    U_.topLeftCorner(c, c).setIdentity();
    for (Index k = 0; k + 1 < Jl; k++) {
        const Index m = (k + 1) * c;
        const Eigen::LLT<Eigen::MatrixXd> lf(Ef);
        if (E_.back().info() != Eigen::Success || lf.info() != Eigen::Success)
            return false;
        // T_{k+1} [F^k; 0] = [E_f; 0 ...; df], T_{k+1} [0; B^k] = [db; 0 ...; E_b]:
        // F^{k+1} = [F^k; 0] + [0; B^k] alpha, B^{k+1} = [0; B^k] + [F^k; 0] beta.
        // The four block products through levinson_kernels.h (the hot loop):
        // df = row_.middleCols((J - 2 - k) c, m) F_.topRows(m), db = top_.middleCols(c, m) B_.bottomRows(m),
        // F_.middleRows(c, m) += B_.bottomRows(m) alpha, B_.middleRows(n - m - c, m) += f_.topRows(m) beta.
        Eigen::MatrixXd df(c, c), db(c, c);
        levinson_product(row_.data() + (Jl - 2 - k) * c * c, c, F_.data(), n, m, int(c), df.data());
        levinson_product(top_.data() + c * c, c, B_.data() + (n - m), n, m, int(c), db.data());
        const Eigen::MatrixXd alpha = -E_.back().solve(df), beta = -lf.solve(db);
        f_.topRows(m) = F_.topRows(m);
        levinson_update(F_.data() + c, B_.data() + (n - m), n, m, int(c), alpha.data());
        levinson_update(B_.data() + (n - m - c), f_.data(), n, m, int(c), beta.data());
        Ef.noalias() += db * alpha;
        Eb.noalias() += df * beta;
        E_.emplace_back(Eb);
        U_.block(0, m, m + c, c) = B_.bottomRows(m + c);
    }
    return E_.back().info() == Eigen::Success;
}

Eigen::VectorXd BlockLevinson::solve(const Eigen::VectorXd &r) const
{
    using Eigen::Index;
    const Index c = Index(C_), J = Index(J_), n = c * J;
    Eigen::VectorXd y(n);
    for (Index j = 0; j < J; j++)
        for (Index a = 0; a < c; a++)
            y(j * c + a) = r(a * J + j);
    y = U_.triangularView<Eigen::UnitUpper>().transpose() * y;
    for (Index j = 0; j < J; j++)
        y.segment(j * c, c) = E_[std::size_t(j)].solve(y.segment(j * c, c));
    y = U_.triangularView<Eigen::UnitUpper>() * y;
    Eigen::VectorXd x(n);
    for (Index j = 0; j < J; j++)
        for (Index a = 0; a < c; a++)
            x(a * J + j) = y(j * c + a);
    return x;
}

bool toeplitz_solve(const ToeplitzOperator &G, BlockLevinson &lev, const Eigen::VectorXd &b, Eigen::VectorXd &x)
{
    if (!lev.factor(G))
        return false;
    const double bound = G.norm_inf() * std::numeric_limits<double>::epsilon() * std::sqrt(double(G.rows()));
    x = lev.solve(b);
    Eigen::VectorXd r(G.rows());
    for (int pass = 0; pass < 10; pass++) {
        G.perform_op(x.data(), r.data());
        r = b - r;
        if (!r.allFinite())
            return false;
        if (r.lpNorm<Eigen::Infinity>() <= bound * x.lpNorm<Eigen::Infinity>())
            return true;
        x += lev.solve(r);
    }
    return false;
}

} // namespace calib::pipeline
