// The edge band of PlateEngine: rows in factored form (plate_operator.h),
// built once, applied every step before the bulk.
#include "engine/plate_engine.h"

#include "engine/edge_kernels.h"

#include <algorithm>
#include <array>
#include <limits>
#include <stdexcept>
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
// Layout (edge_kernels.h): the strains are grouped by their length (1 to 4
// nodes) and the rows by their term counts, each group in blocks of
// edge_lanes that the kernels run as SIMD lanes, with a trip count fixed over
// the group. A strain over fixed nodes only (always zero) is left out of the
// rows. Within a row and a strain the terms keep the order of the operator's
// stencils.
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
                    rows[node][other] += 0.5 * f.weight * own->weight[std::size_t(t)] * own->scale * other_scale;
                }
            }
        }
    };
    add_terms(op.edge_stiffness_terms(), rows_k);
    if (loss.sigma1 > 0)
        add_terms(op.edge_dirichlet_terms(), rows_g);

    using Terms = std::vector<std::pair<std::size_t, double>>; // (stencil, coefficient)
    struct Row {
        std::ptrdiff_t target;
        Terms r, s;
    };
    std::vector<Row> band;
    for (std::size_t u = 0; u < op.unknown_count(); ++u) {
        const std::size_t node = op.node_of()[u];
        const int i = int(node % std::size_t(nx_ + 1)), j = int(node / std::size_t(nx_ + 1));
        if (!op.in_edge_band(i, j))
            continue; // bulk
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
    auto offset32 = [](std::ptrdiff_t o) {
        if (o < 0 || o > std::ptrdiff_t(std::numeric_limits<std::int32_t>::max()))
            throw std::length_error("PlateEngine: field offsets beyond 32 bits");
        return std::int32_t(o);
    };
    constexpr std::size_t L = edge_lanes;

    // Each set keeps the strains its rows read, numbered by length and laid
    // out in blocks (a padded lane: weight 0 on a node of the block).
    auto build_strains = [&](StrainSet &set, Terms Row::*member) {
        set = {};
        std::map<std::size_t, std::uint32_t> index;
        std::array<std::vector<std::size_t>, max_strain_nodes> by_length;
        for (const Row &row : band)
            for (auto [strain, c] : row.*member)
                if (index.try_emplace(strain, 0).second)
                    by_length[std::size_t(stencils[strain].count - 1)].push_back(strain);
        std::uint32_t base = 0;
        for (int len = 1; len <= max_strain_nodes; ++len) {
            const std::vector<std::size_t> &group = by_length[std::size_t(len - 1)];
            const std::size_t blocks = (group.size() + L - 1) / L;
            set.blocks[std::size_t(len - 1)] = blocks;
            for (std::size_t k = 0; k < group.size(); ++k)
                index[group[k]] = base + std::uint32_t(k);
            for (std::size_t blk = 0; blk < blocks; ++blk)
                for (int t = 0; t < len; ++t)
                    for (std::size_t l = 0; l < L; ++l) {
                        const std::size_t k = blk * L + l;
                        const PlateOperator::Stencil &st = stencils[group[k < group.size() ? k : 0]];
                        set.offset.push_back(offset32(offset_of(st.node[std::size_t(t)])));
                        set.weight.push_back(k < group.size() ? T(st.weight[std::size_t(t)]) : T(0));
                    }
            base += std::uint32_t(blocks * L);
        }
        set.value.assign(base, 0.0);
        return index;
    };
    const auto index_r = build_strains(strains_r_, &Row::r);
    const auto index_s = build_strains(strains_s_, &Row::s);

    // Rows: groups of equal term counts, each padded to whole blocks with
    // rows of zero terms on the group's first target (computed, never applied).
    terms_r_ = {};
    terms_s_ = {};
    row_groups_.clear();
    band_target_.clear();
    band_rows_.clear();
    for (std::size_t first = 0; first < band.size();) {
        std::size_t end = first;
        while (end < band.size() && band[end].r.size() == band[first].r.size() &&
               band[end].s.size() == band[first].s.size())
            ++end;
        const std::size_t blocks = (end - first + L - 1) / L;
        const auto r_terms = std::uint32_t(band[first].r.size()), s_terms = std::uint32_t(band[first].s.size());
        row_groups_.push_back({std::uint32_t(blocks), r_terms, s_terms});
        auto lay = [&](std::size_t blk, RowTerms &terms, Terms Row::*member, std::uint32_t count,
                       const std::map<std::size_t, std::uint32_t> &index) {
            for (std::uint32_t e = 0; e < count; ++e)
                for (std::size_t l = 0; l < L; ++l) {
                    const std::size_t n = first + blk * L + l;
                    if (n < end) {
                        const auto [strain, c] = (band[n].*member)[e];
                        terms.strain.push_back(index.at(strain));
                        terms.coef.push_back(T(c));
                    } else {
                        terms.strain.push_back(0);
                        terms.coef.push_back(T(0));
                    }
                }
        };
        for (std::size_t blk = 0; blk < blocks; ++blk) {
            for (std::size_t l = 0; l < L; ++l) {
                const std::size_t n = first + blk * L + l;
                const bool real = n < end;
                if (real)
                    band_rows_.push_back({std::uint32_t(band_target_.size()), band[n].target});
                band_target_.push_back(offset32(band[real ? n : first].target));
            }
            lay(blk, terms_r_, &Row::r, r_terms, index_r);
            lay(blk, terms_s_, &Row::s, s_terms, index_s);
        }
        first = end;
    }
    band_next_.assign(band_target_.size(), 0.0);
}

template <typename T>
template <bool Lossy>
void PlateEngine<T>::edge_band_update()
{
    constexpr std::size_t L = edge_lanes;
    auto strains = [](StrainSet &set, const T *field) {
        const std::int32_t *offset = set.offset.data();
        const T *weight = set.weight.data();
        double *value = set.value.data();
        for (int len = 1; len <= max_strain_nodes; ++len) {
            const std::size_t blocks = set.blocks[std::size_t(len - 1)];
            edge_strains<T>(blocks, len, offset, weight, field, value);
            offset += blocks * std::size_t(len) * L;
            weight += blocks * std::size_t(len) * L;
            value += blocks * L;
        }
    };
    strains(strains_r_, u_);
    if constexpr (Lossy)
        strains(strains_s_, inc_);
    const double g = double(bulk_.g);
    std::size_t r_at = 0, s_at = 0, row = 0;
    for (const RowGroup &group : row_groups_) {
        const EdgeRowTerms r{group.r_terms, terms_r_.strain.data() + r_at, terms_r_.coef.data() + r_at,
                             strains_r_.value.data()};
        const EdgeRowTerms s{Lossy ? group.s_terms : 0, terms_s_.strain.data() + s_at, terms_s_.coef.data() + s_at,
                             strains_s_.value.data()};
        edge_rows<T>(group.blocks, g, band_target_.data() + row, inc_, r, s, band_next_.data() + row);
        r_at += std::size_t(group.blocks) * group.r_terms * L;
        s_at += std::size_t(group.blocks) * group.s_terms * L;
        row += std::size_t(group.blocks) * L;
    }
}

template void PlateEngine<float>::build_edge_rows();
template void PlateEngine<double>::build_edge_rows();
template void PlateEngine<float>::edge_band_update<true>();
template void PlateEngine<float>::edge_band_update<false>();
template void PlateEngine<double>::edge_band_update<true>();
template void PlateEngine<double>::edge_band_update<false>();

} // namespace calib::engine
