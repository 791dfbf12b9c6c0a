// The block products of block Levinson's recursion (block_toeplitz.cpp), the
// design stage's hot loop: per step, two C x C products over the k C rows
// grown so far and two updates of k C rows by a C x C matrix. Eigen compiles
// them for the baseline x86-64 (two doubles a vector) and packs its operands
// on every call; these loops are compiled as the engine's kernels are (-O3,
// run-time ISA dispatch: AVX-512, AVX2+FMA, baseline; engine/plate_kernels.h)
// and read their operands where they are. All matrices column-major.
#pragma once

#include <cstddef>

namespace calib::pipeline {

// out (c x c) = A (c x m, leading dimension lda) * B (m x c, leading dimension ldb).
void levinson_product(const double *A, std::ptrdiff_t lda, const double *B, std::ptrdiff_t ldb, std::ptrdiff_t m, int c,
                      double *out);
// Y (m x c, leading dimension ld) += X (m x c, leading dimension ld) * S (c x c); X and Y do not overlap.
void levinson_update(double *Y, const double *X, std::ptrdiff_t ld, std::ptrdiff_t m, int c, const double *S);

} // namespace calib::pipeline
