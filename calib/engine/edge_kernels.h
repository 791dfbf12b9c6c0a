// Kernels of the edge band (plate_engine_edge.cpp): its strains and its rows
// in blocks of edge_lanes, stored lane-minor (element [block][term][lane]), so
// the lanes are one SIMD vector with gathered loads. Each lane sums its own
// terms in order, in double. Dispatched at run time like the bulk kernel.
#pragma once
#include <cstddef>
#include <cstdint>

namespace calib::engine {

constexpr std::size_t edge_lanes = 8;

// value[b lanes + l] = sum over t < nodes of weight[(b nodes + t) lanes + l] *
// field[offset[(b nodes + t) lanes + l]], for the blocks b < blocks.
template <typename T>
void edge_strains(std::size_t blocks, int nodes, const std::int32_t *offset, const T *weight, const T *field,
                  double *value);

struct EdgeRowTerms {
    std::uint32_t count;         // terms per row
    const std::uint32_t *strain; // [block][term][lane] indices into value
    const void *coef;            // [block][term][lane], of the engine's precision
    const double *value;         // strain values
};

// out[b lanes + l] = g inc[target[...]] - sum of coef value over the terms of
// r, then of s (s.count 0: none).
template <typename T>
void edge_rows(std::size_t blocks, double g, const std::int32_t *target, const T *inc, const EdgeRowTerms &r,
               const EdgeRowTerms &s, double *out);

} // namespace calib::engine
