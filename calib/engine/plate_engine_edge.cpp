// The edge band of PlateEngine: rows in factored form (plate_operator.h),
// built once, applied every step before the bulk.
#include "engine/plate_engine.h"

#include <algorithm>
#include <map>
#include <utility>
#include <vector>

namespace calib::engine {

// Rows for the unknowns of the edge band, in the same form as the bulk kernel:
//   d+ = g d - R u - S d,  u+ = u + d+,
//   R = dd k^2 M^-1 K,  S = dd 2 sigma1 k M^-1 Gm,  dd = 1 / (1 + sigma0 k)
// (u+ = u + g (u - u-) - (R + S) u + S u- written with d = u - u-),
// built from the factored K and Gm (sum of weight (a b^T + b a^T) / 2): row n
// of R u is sum_s coef_ns (s . u) over the strains s. Stored as assembled
// matrix rows instead, the float-rounded coefficients no longer sum to zero
// against a tilt: a free plate's rotation modes then get eigenvalues ~ -1e-10
// of M^-1 K k^2 and grow exponentially (docs/engine.md).
//
// Layout: the strains are numbered by their length (1 to 4 nodes) and the rows
// grouped by their term counts, so every inner loop runs a trip count that is
// fixed across its group. A strain over fixed nodes only (always zero) is
// left out of the rows. Within a row and a strain the terms keep the order of
// the operator's stencils, so the sums are the ones the unordered form makes.
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

    using Terms = std::vector<std::pair<std::size_t, double>>;  // (stencil, coefficient)
    struct Row {
        std::ptrdiff_t target;
        Terms r, s;
    };
    std::vector<Row> band;
    for (std::size_t u = 0; u < op.unknown_count(); ++u) {
        const std::size_t node = op.node_of()[u];
        const int i = int(node % std::size_t(nx_ + 1)), j = int(node / std::size_t(nx_ + 1));
        if (!op.in_edge_band(i, j))
            continue;  // bulk
        const double minv = 1.0 / op.mass()[Eigen::Index(u)];
        Row row{offset_of(node), {}, {}};
        for (auto [strain, c] : rows_k[node])
            if (const double v = d * k_ * k_ * minv * c; v != 0.0 && stencils[strain].count > 0)
                row.r.emplace_back(strain, v);
        for (auto [strain, c] : rows_g[node])
            if (const double v = d * 2 * loss.sigma1 * k_ * minv * c; v != 0.0 && stencils[strain].count > 0)
                row.s.emplace_back(strain, v);
        band.push_back(std::move(row));
    }
    std::stable_sort(band.begin(), band.end(), [](const Row &a, const Row &b) {
        return std::pair{a.r.size(), a.s.size()} < std::pair{b.r.size(), b.s.size()};
    });

    band_target_.clear();
    row_groups_.clear();
    for (const Row &row : band) {
        band_target_.push_back(row.target);
        const auto r_terms = std::uint32_t(row.r.size()), s_terms = std::uint32_t(row.s.size());
        if (row_groups_.empty() || row_groups_.back().r_terms != r_terms || row_groups_.back().s_terms != s_terms)
            row_groups_.push_back({0, r_terms, s_terms});
        row_groups_.back().rows++;
    }
    band_next_.assign(band.size(), 0.0);

    // Each set keeps the strains its rows read, numbered by length.
    auto build = [&](StrainSet &set, RowTerms &terms, Terms Row::*member) {
        set = {};
        terms = {};
        std::vector<std::size_t> used;
        std::map<std::size_t, std::uint32_t> index;
        for (const Row &row : band)
            for (auto [strain, c] : row.*member)
                if (index.try_emplace(strain, 0).second)
                    used.push_back(strain);
        std::stable_sort(used.begin(), used.end(),
                         [&](std::size_t a, std::size_t b) { return stencils[a].count < stencils[b].count; });
        for (std::size_t n = 0; n < used.size(); ++n) {
            const PlateOperator::Stencil &st = stencils[used[n]];
            index[used[n]] = std::uint32_t(n);
            for (int t = 0; t < st.count; ++t) {
                set.offset.push_back(offset_of(st.node[std::size_t(t)]));
                set.weight.push_back(T(st.weight[std::size_t(t)]));
            }
            for (int len = st.count; len <= max_strain_nodes; ++len)
                set.length_end[std::size_t(len)] = std::uint32_t(n + 1);
        }
        set.value.assign(used.size(), 0.0);
        for (const Row &row : band)
            for (auto [strain, c] : row.*member) {
                terms.strain.push_back(index[strain]);
                terms.coef.push_back(T(c));
            }
    };
    build(strains_r_, terms_r_, &Row::r);
    build(strains_s_, terms_s_, &Row::s);
}

namespace {

// value[s] = sum of weight * field over the nodes of strain s, in double,
// group by group (a strain of L nodes in the group L).
template <typename T, int L>
void strain_group(std::uint32_t count, const std::ptrdiff_t *&offset, const T *&weight, double *&value,
                  const T *field)
{
    for (std::uint32_t s = 0; s < count; ++s, offset += L, weight += L) {
        double v = 0;
        for (int t = 0; t < L; ++t)
            v += double(weight[t]) * double(field[offset[t]]);
        *value++ = v;
    }
}

}  // namespace

template <typename T>
template <bool Lossy>
void PlateEngine<T>::edge_band_update()
{
    static_assert(max_strain_nodes == 4, "strain_group is unrolled for 1 to 4 nodes");
    auto strains = [](StrainSet &set, const T *field) {
        const std::ptrdiff_t *offset = set.offset.data();
        const T *weight = set.weight.data();
        double *value = set.value.data();
        const auto &end = set.length_end;
        strain_group<T, 1>(end[1] - end[0], offset, weight, value, field);
        strain_group<T, 2>(end[2] - end[1], offset, weight, value, field);
        strain_group<T, 3>(end[3] - end[2], offset, weight, value, field);
        strain_group<T, 4>(end[4] - end[3], offset, weight, value, field);
    };
    strains(strains_r_, u_);
    if constexpr (Lossy)
        strains(strains_s_, inc_);
    const double g = double(bulk_.g);
    const std::uint32_t *r_strain = terms_r_.strain.data(), *s_strain = terms_s_.strain.data();
    const T *r_coef = terms_r_.coef.data(), *s_coef = terms_s_.coef.data();
    const double *r_value = strains_r_.value.data(), *s_value = strains_s_.value.data();
    std::size_t r = 0;
    for (const RowGroup &group : row_groups_) {
        for (std::uint32_t n = 0; n < group.rows; ++n, ++r) {
            double v = g * double(inc_[band_target_[r]]);
            for (std::uint32_t e = 0; e < group.r_terms; ++e)
                v -= double(r_coef[e]) * r_value[r_strain[e]];
            r_coef += group.r_terms;
            r_strain += group.r_terms;
            if constexpr (Lossy) {
                for (std::uint32_t e = 0; e < group.s_terms; ++e)
                    v -= double(s_coef[e]) * s_value[s_strain[e]];
                s_coef += group.s_terms;
                s_strain += group.s_terms;
            }
            band_next_[r] = v;
        }
    }
}

template void PlateEngine<float>::build_edge_rows();
template void PlateEngine<double>::build_edge_rows();
template void PlateEngine<float>::edge_band_update<true>();
template void PlateEngine<float>::edge_band_update<false>();
template void PlateEngine<double>::edge_band_update<true>();
template void PlateEngine<double>::edge_band_update<false>();

}  // namespace calib::engine
