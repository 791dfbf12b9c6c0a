#include "pipeline/design/levinson_kernels.h"

#include "engine/plate_kernels.h"

#include <algorithm>

namespace calib::pipeline {

namespace {

// out[b][a] = sum_i A[a + i lda] B[i + b ldb]: for each i, A's column i (c
// contiguous values) times the c values of B's row i, into c x c sums.
inline __attribute__((always_inline)) void product_body(const double *__restrict A, std::ptrdiff_t lda,
                                                        const double *__restrict B, std::ptrdiff_t ldb,
                                                        std::ptrdiff_t m, int c, double *__restrict out)
{
    std::fill(out, out + std::ptrdiff_t(c) * c, 0.0);
    if (c == 8 && lda == 8) { // the product's usual shape: 8 exciters, 64 sums kept in registers
        double acc[8][8] = {};
        for (std::ptrdiff_t i = 0; i < m; ++i) {
            const double *a = A + i * 8;
            for (int b = 0; b < 8; ++b) {
                const double v = B[i + b * ldb];
#pragma omp simd
                for (int r = 0; r < 8; ++r)
                    acc[b][r] += a[r] * v;
            }
        }
        for (int b = 0; b < 8; ++b)
            for (int r = 0; r < 8; ++r)
                out[b * 8 + r] = acc[b][r];
        return;
    }
    for (int b = 0; b < c; ++b)
        for (std::ptrdiff_t i = 0; i < m; ++i) {
            const double v = B[i + b * ldb];
            const double *a = A + i * lda;
#pragma omp simd
            for (int r = 0; r < c; ++r)
                out[b * c + r] += a[r] * v;
        }
}

// Y[:, b] += sum_a S[a + b c] X[:, a], a in order (both paths: the same sums),
// in blocks of rows that stay in L1.
inline __attribute__((always_inline)) void update_body(double *__restrict Y, const double *__restrict X,
                                                       std::ptrdiff_t ld, std::ptrdiff_t m, int c,
                                                       const double *__restrict S)
{
    std::ptrdiff_t done = 0;
    if (c == 8) { // the usual shape: per 8 rows, X's 8 x 8 values in registers, each Y value loaded once
        for (; done + 8 <= m; done += 8) {
            double x[8][8];
            for (int a = 0; a < 8; ++a)
#pragma omp simd
                for (int l = 0; l < 8; ++l)
                    x[a][l] = X[a * ld + done + l];
            for (int b = 0; b < 8; ++b) {
                double acc[8];
                double *y = Y + b * ld + done;
#pragma omp simd
                for (int l = 0; l < 8; ++l)
                    acc[l] = y[l];
                for (int a = 0; a < 8; ++a) {
                    const double s = S[a + b * 8];
#pragma omp simd
                    for (int l = 0; l < 8; ++l)
                        acc[l] += s * x[a][l];
                }
#pragma omp simd
                for (int l = 0; l < 8; ++l)
                    y[l] = acc[l];
            }
        }
        Y += done;
        X += done;
        m -= done;
    }
    constexpr std::ptrdiff_t block = 256;
    for (std::ptrdiff_t i0 = 0; i0 < m; i0 += block) {
        const std::ptrdiff_t n = std::min(block, m - i0);
        for (int b = 0; b < c; ++b) {
            double *y = Y + b * ld + i0;
            for (int a = 0; a < c; ++a) {
                const double s = S[a + b * c];
                const double *x = X + a * ld + i0;
#pragma omp simd
                for (std::ptrdiff_t i = 0; i < n; ++i)
                    y[i] += s * x[i];
            }
        }
    }
}

using ProductFn = void (*)(const double *, std::ptrdiff_t, const double *, std::ptrdiff_t, std::ptrdiff_t, int,
                           double *);
using UpdateFn = void (*)(double *, const double *, std::ptrdiff_t, std::ptrdiff_t, int, const double *);

#define HAPTIC_LEVINSON_VARIANT(SUFFIX, ATTR)                                                                          \
    ATTR void product_##SUFFIX(const double *A, std::ptrdiff_t lda, const double *B, std::ptrdiff_t ldb,               \
                               std::ptrdiff_t m, int c, double *out)                                                   \
    {                                                                                                                  \
        product_body(A, lda, B, ldb, m, c, out);                                                                       \
    }                                                                                                                  \
    ATTR void update_##SUFFIX(double *Y, const double *X, std::ptrdiff_t ld, std::ptrdiff_t m, int c, const double *S) \
    {                                                                                                                  \
        update_body(Y, X, ld, m, c, S);                                                                                \
    }

HAPTIC_LEVINSON_VARIANT(baseline, )
#ifdef HAPTIC_DISPATCH
HAPTIC_LEVINSON_VARIANT(avx512, HAPTIC_ISA_AVX512)
HAPTIC_LEVINSON_VARIANT(avx2, HAPTIC_ISA_AVX2)
#endif

} // namespace

void levinson_product(const double *A, std::ptrdiff_t lda, const double *B, std::ptrdiff_t ldb, std::ptrdiff_t m, int c,
                      double *out)
{
    static const ProductFn fn = HAPTIC_PICK_ISA(ProductFn, product_avx512, product_avx2, product_baseline);
    fn(A, lda, B, ldb, m, c, out);
}

void levinson_update(double *Y, const double *X, std::ptrdiff_t ld, std::ptrdiff_t m, int c, const double *S)
{
    static const UpdateFn fn = HAPTIC_PICK_ISA(UpdateFn, update_avx512, update_avx2, update_baseline);
    fn(Y, X, ld, m, c, S);
}

} // namespace calib::pipeline
