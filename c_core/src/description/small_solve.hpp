// Dense solves of the described robots' dynamics at their sizes (n <= 6): plain loops over
// fixed arrays compiled per size N, which the compiler unrolls; a few times faster than
// Eigen's general LU and LLT at these sizes, and the dynamics run at every integrator stage.
// with_size(n, f) calls f(std::integral_constant<int, N>) for N = n, so that the callers'
// loops are compiled per size too.
#pragma once

#include <cmath>
#include <type_traits>

#include "description/described_state.hpp"

namespace pkm {
namespace described {

template <class F>
inline auto with_size(int n, F&& f) {
  switch (n) {
    case 1: return f(std::integral_constant<int, 1>());
    case 2: return f(std::integral_constant<int, 2>());
    case 3: return f(std::integral_constant<int, 3>());
    case 4: return f(std::integral_constant<int, 4>());
    case 5: return f(std::integral_constant<int, 5>());
    default: return f(std::integral_constant<int, 6>());
  }
}

// GCC's -Wmaybe-uninitialized reads L[i][k] (k < j) as possibly unset once the loops are
// unrolled; every such entry is written at an earlier column j.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

// Cholesky factor of a symmetric positive-definite N x N matrix (its lower triangle) and
// solves with it.
template <int N>
struct SmallCholesky {
  double L[N][N], inv[N];  // inv: reciprocals of the diagonal
  bool factor(const M6& A) {  // false: a pivot is not positive (A not positive definite)
    for (int j = 0; j < N; ++j) {
      double d = A(j, j);
      for (int k = 0; k < j; ++k) d -= L[j][k] * L[j][k];
      if (!(d > 0)) return false;
      inv[j] = 1.0 / std::sqrt(d);
      for (int i = j + 1; i < N; ++i) {
        double s = A(i, j);
        for (int k = 0; k < j; ++k) s -= L[i][k] * L[j][k];
        L[i][j] = s * inv[j];
      }
    }
    return true;
  }
  V6 solve(const V6& b) const {  // entries N.. of the result are zero
    V6 y, x = V6::Zero();
    for (int i = 0; i < N; ++i) {
      double s = b[i];
      for (int k = 0; k < i; ++k) s -= L[i][k] * y[k];
      y[i] = s * inv[i];
    }
    for (int i = N - 1; i >= 0; --i) {
      double s = y[i];
      for (int k = i + 1; k < N; ++k) s -= L[k][i] * x[k];
      x[i] = s * inv[i];
    }
    return x;
  }
};

// A x = b for a square N x N matrix by Gaussian elimination with partial (row) pivoting, as
// Eigen's PartialPivLU; false when a pivot is below 1e-13 times the largest (at least 1):
// A is singular.
template <int N>
bool small_lu_solve(double (&a)[N][N], double (&b)[N], double (&x)[N]) {
  double pmax = 1.0, pmin = HUGE_VAL;
  for (int k = 0; k < N; ++k) {
    int p = k;
    for (int i = k + 1; i < N; ++i)
      if (std::abs(a[i][k]) > std::abs(a[p][k])) p = i;
    if (p != k) {
      for (int j = 0; j < N; ++j) std::swap(a[k][j], a[p][j]);
      std::swap(b[k], b[p]);
    }
    const double piv = a[k][k];
    pmax = std::fmax(pmax, std::abs(piv));
    pmin = std::fmin(pmin, std::abs(piv));
    if (!(piv != 0)) return false;
    const double inv = 1.0 / piv;
    for (int i = k + 1; i < N; ++i) {
      const double f = a[i][k] * inv;
      for (int j = k + 1; j < N; ++j) a[i][j] -= f * a[k][j];
      b[i] -= f * b[k];
    }
  }
  if (!(pmin > 1e-13 * pmax)) return false;
  for (int i = N - 1; i >= 0; --i) {
    double s = b[i];
    for (int j = i + 1; j < N; ++j) s -= a[i][j] * x[j];
    x[i] = s / a[i][i];
  }
  return true;
}

#pragma GCC diagnostic pop

}  // namespace described
}  // namespace pkm
