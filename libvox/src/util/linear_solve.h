// Small dense linear systems, solved in place without allocation, for the least-squares fits'
// normal equations. Header-only: the solver compiles with the including file's floating-point
// options (built with -ffp-contract=off, as the block encoders are, its results are the same on
// every x86-64 build).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>

namespace vox::detail {

/// Solves m·y = r (r becomes y) for a symmetric positive definite m of order N ≤ Size by Cholesky
/// factorisation: the lower triangle of m's leading N×N block is used and overwritten by the
/// factor; entries beyond N are not touched. False when m is not numerically positive definite
/// (a pivot not above 0). The loops are unrolled (up to 9 iterations): for the small orders this
/// is meant for, the loops' overhead cost more than their arithmetic.
template <unsigned N, std::size_t Size>
bool solveCholesky(std::array<std::array<double, Size>, Size>& m, std::array<double, Size>& r) {
    static_assert(N <= Size);
#pragma GCC unroll 9
    for (unsigned j = 0; j < N; ++j) {
        double d = m[j][j];
#pragma GCC unroll 9
        for (unsigned k = 0; k < j; ++k) d -= m[j][k] * m[j][k];
        if (!(d > 0)) return false;
        d = std::sqrt(d);
        m[j][j] = d;
#pragma GCC unroll 9
        for (unsigned i = j + 1; i < N; ++i) {
            double s = m[i][j];
#pragma GCC unroll 9
            for (unsigned k = 0; k < j; ++k) s -= m[i][k] * m[j][k];
            m[i][j] = s / d;
        }
    }
#pragma GCC unroll 9
    for (unsigned i = 0; i < N; ++i) {
        double s = r[i];
#pragma GCC unroll 9
        for (unsigned k = 0; k < i; ++k) s -= m[i][k] * r[k];
        r[i] = s / m[i][i];
    }
#pragma GCC unroll 9
    for (unsigned t = 0; t < N; ++t) {
        const unsigned i = N - 1 - t;
        double s = r[i];
#pragma GCC unroll 9
        for (unsigned k = i + 1; k < N; ++k) s -= m[k][i] * r[k];
        r[i] = s / m[i][i];
    }
    return true;
}

}  // namespace vox::detail
