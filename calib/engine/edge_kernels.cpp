#include "engine/edge_kernels.h"

#include "engine/plate_kernels.h"

namespace calib::engine {

namespace {

template <typename T>
inline void strains_body(std::size_t blocks, int nodes, const std::int32_t *offset, const T *weight, const T *field,
                         double *value)
{
    constexpr std::size_t L = edge_lanes;
    for (std::size_t b = 0; b < blocks; ++b) {
        double acc[L] = {};
        for (int t = 0; t < nodes; ++t, offset += L, weight += L)
            for (std::size_t l = 0; l < L; ++l)
                acc[l] += double(weight[l]) * double(field[offset[l]]);
        for (std::size_t l = 0; l < L; ++l)
            value[b * L + l] = acc[l];
    }
}

template <typename T>
inline void rows_body(std::size_t blocks, double g, const std::int32_t *target, const T *inc, const EdgeRowTerms &r,
                      const EdgeRowTerms &s, double *out)
{
    constexpr std::size_t L = edge_lanes;
    const std::uint32_t *rs = r.strain, *ss = s.strain;
    const T *rc = static_cast<const T *>(r.coef), *sc = static_cast<const T *>(s.coef);
    for (std::size_t b = 0; b < blocks; ++b) {
        double v[L];
        for (std::size_t l = 0; l < L; ++l)
            v[l] = g * double(inc[target[b * L + l]]);
        for (std::uint32_t e = 0; e < r.count; ++e, rs += L, rc += L)
            for (std::size_t l = 0; l < L; ++l)
                v[l] -= double(rc[l]) * r.value[rs[l]];
        for (std::uint32_t e = 0; e < s.count; ++e, ss += L, sc += L)
            for (std::size_t l = 0; l < L; ++l)
                v[l] -= double(sc[l]) * s.value[ss[l]];
        for (std::size_t l = 0; l < L; ++l)
            out[b * L + l] = v[l];
    }
}

template <typename T>
using StrainsFn = void (*)(std::size_t, int, const std::int32_t *, const T *, const T *, double *);
template <typename T>
using RowsFn = void (*)(std::size_t, double, const std::int32_t *, const T *, const EdgeRowTerms &,
                        const EdgeRowTerms &, double *);

#define HAPTIC_EDGE_VARIANT(SUFFIX, ATTR)                                                                              \
    template <typename T>                                                                                              \
    ATTR void strains_##SUFFIX(std::size_t blocks, int nodes, const std::int32_t *offset, const T *weight,             \
                               const T *field, double *value)                                                          \
    {                                                                                                                  \
        strains_body<T>(blocks, nodes, offset, weight, field, value);                                                  \
    }                                                                                                                  \
    template <typename T>                                                                                              \
    ATTR void rows_##SUFFIX(std::size_t blocks, double g, const std::int32_t *target, const T *inc,                    \
                            const EdgeRowTerms &r, const EdgeRowTerms &s, double *out)                                 \
    {                                                                                                                  \
        rows_body<T>(blocks, g, target, inc, r, s, out);                                                               \
    }

HAPTIC_EDGE_VARIANT(baseline, )
#ifdef HAPTIC_DISPATCH
HAPTIC_EDGE_VARIANT(avx512, HAPTIC_ISA_AVX512)
HAPTIC_EDGE_VARIANT(avx2, HAPTIC_ISA_AVX2)
#endif

} // namespace

template <typename T>
void edge_strains(std::size_t blocks, int nodes, const std::int32_t *offset, const T *weight, const T *field,
                  double *value)
{
    static const StrainsFn<T> fn =
        HAPTIC_PICK_ISA(StrainsFn<T>, strains_avx512<T>, strains_avx2<T>, strains_baseline<T>);
    fn(blocks, nodes, offset, weight, field, value);
}

template <typename T>
void edge_rows(std::size_t blocks, double g, const std::int32_t *target, const T *inc, const EdgeRowTerms &r,
               const EdgeRowTerms &s, double *out)
{
    static const RowsFn<T> fn = HAPTIC_PICK_ISA(RowsFn<T>, rows_avx512<T>, rows_avx2<T>, rows_baseline<T>);
    fn(blocks, g, target, inc, r, s, out);
}

template void edge_strains<float>(std::size_t, int, const std::int32_t *, const float *, const float *, double *);
template void edge_strains<double>(std::size_t, int, const std::int32_t *, const double *, const double *, double *);
template void edge_rows<float>(std::size_t, double, const std::int32_t *, const float *, const EdgeRowTerms &,
                               const EdgeRowTerms &, double *);
template void edge_rows<double>(std::size_t, double, const std::int32_t *, const double *, const EdgeRowTerms &,
                                const EdgeRowTerms &, double *);

} // namespace calib::engine
