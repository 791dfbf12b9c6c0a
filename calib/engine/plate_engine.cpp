#include "engine/plate_engine.h"

#include <omp.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <map>
#include <new>
#include <stdexcept>
#include <tuple>

#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#define HAPTIC_HAVE_MXCSR 1
#endif

namespace calib::engine {

ScopedFlushDenormals::ScopedFlushDenormals()
{
#ifdef HAPTIC_HAVE_MXCSR
    saved_ = _mm_getcsr();
    const unsigned ftz_daz = saved_ | 0x8040u;
    _mm_setcsr(ftz_daz);
#pragma omp parallel
    _mm_setcsr(ftz_daz);
#endif
}

ScopedFlushDenormals::~ScopedFlushDenormals()
{
#ifdef HAPTIC_HAVE_MXCSR
    const unsigned saved = saved_;
#pragma omp parallel
    _mm_setcsr(saved);
    _mm_setcsr(saved);
#endif
}

template <typename T>
PlateEngine<T>::PlateEngine(std::shared_ptr<const PlateOperator> op, double time_step_s, const EngineOptions &options)
    : op_(std::move(op)), options_(options), k_(time_step_s)
{
    if (!op_)
        throw std::invalid_argument("PlateEngine: no operator");
    if (!options_.skip_stability_check)
        op_->check_time_step(k_);
    const Grid &g = op_->grid();
    nx_ = g.nx;
    ny_ = g.ny;
    // Rows padded to whole 64-byte lines so every row starts aligned.
    const std::ptrdiff_t per_line = std::ptrdiff_t(64 / sizeof(T));
    stride_ = (std::ptrdiff_t(nx_ + 1) + per_line - 1) / per_line * per_line;
    if (nx_ > 3 && ny_ > 3) {
        const std::size_t cells = std::size_t(nx_ - 3) * std::size_t(ny_ - 3);
        const int threads = options_.threads > 0 ? options_.threads : omp_get_max_threads();
        bulk_threads_ = cells >= options_.parallel_min_cells ? std::max(1, threads) : 1;
    }
    const std::size_t level = std::size_t(stride_) * std::size_t(ny_ + 1);
    const std::size_t scratch = std::size_t(stride_) * std::size_t(bulk_threads_ * bulk_scratch_rows);
    const std::size_t total = 3 * level + scratch;
    storage_ = static_cast<T *>(std::aligned_alloc(64, total * sizeof(T)));
    if (!storage_)
        throw std::bad_alloc();
    std::memset(static_cast<void *>(storage_), 0, total * sizeof(T));
    u_ = storage_;
    inc_ = storage_ + level;
    inc_before_ = storage_ + 2 * level;
    scratch_ = storage_ + 3 * level;

    const Loss &loss = op_->params().loss;
    lossy_ = loss.active();
    const double h = g.h;
    const double mu2 = op_->kappa() * op_->kappa() * k_ * k_ / (h * h * h * h);
    const double nu1 = 2 * loss.sigma1 * k_ / (h * h);
    const double d = 1.0 / (1.0 + loss.sigma0 * k_);
    bulk_.g = T(d * (1 - loss.sigma0 * k_));
    bulk_.mu2 = T(d * mu2);
    bulk_.nu1 = T(d * nu1);
    build_edge_rows();
    build_rigid_modes();
}

template <typename T>
PlateEngine<T>::~PlateEngine()
{
    std::free(storage_);
}

template <typename T>
std::ptrdiff_t PlateEngine<T>::offset_of(std::size_t node) const
{
    const std::size_t i = node % std::size_t(nx_ + 1), j = node / std::size_t(nx_ + 1);
    return std::ptrdiff_t(j) * stride_ + std::ptrdiff_t(i);
}

template <typename T>
double PlateEngine<T>::force_gain(std::size_t node) const
{
    const std::ptrdiff_t u = op_->unknown_of()[node];
    if (u < 0)
        return 0.0;
    const double d = 1.0 / (1.0 + op_->params().loss.sigma0 * k_);
    return d * k_ * k_ / op_->mass()[u];
}

// Rows for the unknowns of the edge band, in the same form as the bulk kernel:
//   d+ = g d - R u - S d,  u+ = u + d+,
//   R = dd k^2 M^-1 K,  S = dd 2 sigma1 k M^-1 Gm,  dd = 1 / (1 + sigma0 k)
// (u+ = u + g (u - u-) - (R + S) u + S u- written with d = u - u-),
// built from the factored K and Gm (sum of weight (a b^T + b a^T) / 2): row n
// of R u is sum_s coef_ns (s . u) over the strains s. Stored as assembled
// matrix rows instead, the float-rounded coefficients no longer sum to zero
// against a tilt: a free plate's rotation modes then get eigenvalues ~ -1e-10
// of M^-1 K k^2 and grow exponentially (docs/engine.md).
template <typename T>
void PlateEngine<T>::build_edge_rows()
{
    const PlateOperator &op = *op_;
    const Loss &loss = op.params().loss;
    const double d = 1.0 / (1.0 + loss.sigma0 * k_);
    const auto &stencils = op.edge_stencils();
    // Per band node: sum over terms of weight/2 (a_n (b . u) + b_n (a . u)),
    // as a map strain -> coefficient (before the 1/m_n scaling).
    std::map<std::size_t, std::map<std::size_t, double>> rows_k, rows_g;
    auto add_terms = [&](const std::vector<PlateOperator::FormTerm> &terms,
                         std::map<std::size_t, std::map<std::size_t, double>> &rows) {
        for (const auto &f : terms) {
            const PlateOperator::Stencil &sa = stencils[f.a], &sb = stencils[f.b];
            for (auto [own, other] : {std::pair{&sa, f.b}, std::pair{&sb, f.a}}) {
                const double other_scale = stencils[other].scale;
                for (int t = 0; t < own->count; ++t) {
                    const std::size_t node = own->node[std::size_t(t)];
                    const int i = int(node % std::size_t(nx_ + 1)), j = int(node / std::size_t(nx_ + 1));
                    if (!op.in_edge_band(i, j))
                        continue;
                    rows[node][other] +=
                        0.5 * f.weight * own->weight[std::size_t(t)] * own->scale * other_scale;
                }
            }
        }
    };
    add_terms(op.edge_stiffness_terms(), rows_k);
    if (loss.sigma1 > 0)
        add_terms(op.edge_dirichlet_terms(), rows_g);

    for (StrainRows *rows : {&edge_r_, &edge_s_}) {
        *rows = {};
        rows->start.assign(1, 0);
        rows->strain_start.assign(1, 0);
    }
    // Each StrainRows keeps the strains it reads, renumbered.
    auto strain_index = [&](StrainRows &rows, std::map<std::size_t, std::uint32_t> &index, std::size_t s) {
        auto [it, fresh] = index.try_emplace(s, std::uint32_t(index.size()));
        if (fresh) {
            const PlateOperator::Stencil &st = stencils[s];
            for (int t = 0; t < st.count; ++t) {
                rows.strain_offset.push_back(offset_of(st.node[std::size_t(t)]));
                rows.strain_weight.push_back(T(st.weight[std::size_t(t)]));
            }
            rows.strain_start.push_back(std::uint32_t(rows.strain_offset.size()));
        }
        return it->second;
    };
    std::map<std::size_t, std::uint32_t> index_r, index_s;
    for (std::size_t u = 0; u < op.unknown_count(); ++u) {
        const std::size_t node = op.node_of()[u];
        const int i = int(node % std::size_t(nx_ + 1)), j = int(node / std::size_t(nx_ + 1));
        if (!op.in_edge_band(i, j))
            continue;  // bulk
        const double minv = 1.0 / op.mass()[Eigen::Index(u)];
        std::map<std::size_t, double> r, s;
        for (auto [strain, c] : rows_k[node])
            r[strain] += d * k_ * k_ * minv * c;
        for (auto [strain, c] : rows_g[node])
            s[strain] += d * 2 * loss.sigma1 * k_ * minv * c;
        for (auto [rows, src, index] : {std::tuple{&edge_r_, &r, &index_r}, std::tuple{&edge_s_, &s, &index_s}}) {
            rows->target.push_back(offset_of(node));
            for (auto [strain, c] : *src)
                if (c != 0.0) {
                    rows->strain.push_back(strain_index(*rows, *index, strain));
                    rows->coef.push_back(T(c));
                }
            rows->start.push_back(std::uint32_t(rows->strain.size()));
        }
    }
    edge_r_.strain_value.assign(edge_r_.strain_start.size() - 1, T(0));
    edge_s_.strain_value.assign(edge_s_.strain_start.size() - 1, T(0));
    band_next_.assign(edge_r_.target.size(), 0.0);
}

// Every rigid_interval steps a free plate's rigid-body momenta are restored
// to their exact values (plate_engine_rigid.cpp).
constexpr std::size_t rigid_interval = 16;

template <typename T>
void PlateEngine<T>::add_displacement(std::ptrdiff_t offset, T delta_m)
{
    u_[offset] += delta_m;
    inc_[offset] += delta_m;
    if (rigid_count_ == 0)
        return;
    const int i = int(offset % stride_), j = int(offset / stride_);
    const std::ptrdiff_t u = op_->unknown_of()[op_->grid().node(i, j)];
    if (u < 0)
        return;
    const double md = op_->mass()[Eigen::Index(u)] * double(delta_m);
    for (int c = 0; c < rigid_count_; ++c) {
        const auto &b = rigid_b_[std::size_t(c)];
        rigid_expected_[std::size_t(c)] += md * (b[0] + b[1] * i + b[2] * j);
    }
}

template <typename T>
std::size_t PlateEngine<T>::add_source(double x_m, double y_m)
{
    PointTap tap;
    for (const auto &nw : op_->point_weights(x_m, y_m)) {
        tap.offset.push_back(offset_of(nw.node));
        tap.weight.push_back(T(nw.weight * force_gain(nw.node)));
    }
    sources_.push_back(std::move(tap));
    return sources_.size() - 1;
}

template <typename T>
std::size_t PlateEngine<T>::add_receiver(double x_m, double y_m)
{
    PointTap tap;
    for (const auto &nw : op_->point_weights(x_m, y_m)) {
        tap.offset.push_back(offset_of(nw.node));
        tap.weight.push_back(T(nw.weight));
    }
    receivers_.push_back(std::move(tap));
    return receivers_.size() - 1;
}

template <typename T>
double PlateEngine<T>::receiver_value(std::size_t r) const
{
    const PointTap &tap = receivers_[r];
    double v = 0;
    for (std::size_t n = 0; n < tap.offset.size(); ++n)
        v += double(tap.weight[n]) * double(u_[tap.offset[n]]);
    return v;
}

template <typename T>
void PlateEngine<T>::step()
{
    if (lossy_)
        step_impl<true>();
    else
        step_impl<false>();
}

template <typename T>
template <bool Lossy>
void PlateEngine<T>::step_impl()
{
    // The edge band first, into band_next_: its strains read u^n and d^n
    // around the band, which the bulk then updates in place.
    auto strains = [](StrainRows &rows, const T *field) {
        const std::size_t n = rows.strain_value.size();
        for (std::size_t s = 0; s < n; ++s) {
            double v = 0;
            for (std::uint32_t e = rows.strain_start[s]; e < rows.strain_start[s + 1]; ++e)
                v += double(rows.strain_weight[e]) * double(field[rows.strain_offset[e]]);
            rows.strain_value[s] = v;
        }
    };
    strains(edge_r_, u_);
    if constexpr (Lossy)
        strains(edge_s_, inc_);
    const std::size_t rows = edge_r_.target.size();
    const double g = double(bulk_.g);
    for (std::size_t r = 0; r < rows; ++r) {
        double v = g * double(inc_[edge_r_.target[r]]);
        for (std::uint32_t e = edge_r_.start[r]; e < edge_r_.start[r + 1]; ++e)
            v -= double(edge_r_.coef[e]) * edge_r_.strain_value[edge_r_.strain[e]];
        if constexpr (Lossy) {
            for (std::uint32_t e = edge_s_.start[r]; e < edge_s_.start[r + 1]; ++e)
                v -= double(edge_s_.coef[e]) * edge_s_.strain_value[edge_s_.strain[e]];
        }
        band_next_[r] = v;
    }
    // The bulk: d^{n+1} into inc_before_ (d^{n-1} is no longer needed), u in place.
    const int i0 = 2, i1 = nx_ - 1, j0 = 2, j1 = ny_ - 1;
    if (i1 > i0 && j1 > j0)
        bulk_update_threads<T, Lossy>(u_, inc_, inc_before_, stride_, i0, i1, j0, j1, bulk_, bulk_threads_, scratch_);
    for (std::size_t r = 0; r < rows; ++r) {
        const std::ptrdiff_t self = edge_r_.target[r];
        const T v = T(band_next_[r]);
        inc_before_[self] = v;
        u_[self] += v;
    }
    std::swap(inc_, inc_before_);
    for (int c = 0; c < rigid_count_; ++c)
        rigid_expected_[std::size_t(c)] *= g;
    for (PointTap &src : sources_) {
        if (src.force == T(0))
            continue;
        for (std::size_t n = 0; n < src.offset.size(); ++n)
            add_displacement(src.offset[n], src.weight[n] * src.force);
    }
    ++steps_;
    if (rigid_count_ > 0 && steps_ % rigid_interval == 0)
        restore_rigid_momenta();
    for (auto &ext : extensions_)
        ext->after_update(*this);
}

template <typename T>
double PlateEngine<T>::energy() const
{
    const PlateOperator &op = *op_;
    const Eigen::Index n = Eigen::Index(op.unknown_count());
    Eigen::VectorXd a(n), inc(n);
    for (Eigen::Index u = 0; u < n; ++u) {
        const std::ptrdiff_t off = offset_of(op.node_of()[std::size_t(u)]);
        a[u] = double(u_[off]);
        inc[u] = double(inc_[off]);
    }
    const Eigen::VectorXd b = a - inc;
    const Eigen::VectorXd v = inc / k_;
    double kinetic = v.dot(op.mass().cwiseProduct(v));
    const double sigma1 = op.params().loss.sigma1;
    if (sigma1 > 0)
        kinetic -= sigma1 * k_ * v.dot(op.dirichlet() * v);
    const double potential = a.dot(op.stiffness() * b);
    return 0.5 * kinetic + 0.5 * potential;
}

template <typename T>
std::vector<double> PlateEngine<T>::displacement() const
{
    std::vector<double> out(std::size_t(nx_ + 1) * std::size_t(ny_ + 1));
    for (int j = 0; j <= ny_; ++j)
        for (int i = 0; i <= nx_; ++i)
            out[std::size_t(j) * std::size_t(nx_ + 1) + std::size_t(i)] = double(u_[j * stride_ + i]);
    return out;
}

template <typename T>
void PlateEngine<T>::set_state(const std::vector<double> &current, const std::vector<double> &previous)
{
    const std::size_t nodes = op_->grid().node_count();
    if (current.size() != nodes || previous.size() != nodes)
        throw std::invalid_argument("PlateEngine::set_state: field size does not match the grid");
    for (std::size_t node = 0; node < nodes; ++node) {
        const bool fixed = op_->unknown_of()[node] < 0;
        u_[offset_of(node)] = fixed ? T(0) : T(current[node]);
        inc_[offset_of(node)] = fixed ? T(0) : T(current[node] - previous[node]);
        inc_before_[offset_of(node)] = T(0);
    }
    const auto raw = raw_moments();
    for (int c = 0; c < rigid_count_; ++c) {
        const auto &b = rigid_b_[std::size_t(c)];
        rigid_expected_[std::size_t(c)] = b[0] * raw[0] + b[1] * raw[1] + b[2] * raw[2];
    }
}

template class PlateEngine<float>;
template class PlateEngine<double>;

}  // namespace calib::engine
