// Forward-mode differentiation for the description-compiled robots (described_robot.cpp).
//
// A described robot writes its geometry once, as a template over the scalar type: the
// positions of its body points as functions of the pose.  Evaluated with
//  * Grad<N>: value and the N partial derivatives -> every Jacobian, exact to rounding;
//  * Taylor2: value, first and second derivative along one path x(t) = x + t xd + t^2/2 xdd
//    -> velocities and accelerations (J xdd + Jdot xd), exact to rounding.
// No finite differences: the dynamics stay energy-consistent and equal to hand-derived
// formulas to rounding.
#pragma once

#include <cmath>

#include "common/fast_math.hpp"

namespace pkm {
namespace described {

// Value and gradient over at most N variables (the first n used).  S is the scalar of the
// value and the partials: double, or Taylor2 for the time derivative of a gradient (Jdot).
template <int N, class S = double>
struct Grad {
  S v;
  S d[N];
  Grad() {}  // uninitialised, like a double: every operation writes all fields
  Grad(double x) : v(x) {  // NOLINT: constants mix freely with variables
    for (int i = 0; i < N; ++i) d[i] = S(0.0);
  }
  static Grad variable(const S& x, int i) {
    Grad g(0.0);
    g.v = x;
    g.d[i] = S(1.0);
    return g;
  }
};

template <int N, class S> inline Grad<N, S> operator+(const Grad<N, S>& a, const Grad<N, S>& b) {
  Grad<N, S> r;
  r.v = a.v + b.v;
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] + b.d[i];
  return r;
}
template <int N, class S> inline Grad<N, S> operator-(const Grad<N, S>& a, const Grad<N, S>& b) {
  Grad<N, S> r;
  r.v = a.v - b.v;
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] - b.d[i];
  return r;
}
template <int N, class S> inline Grad<N, S> operator-(const Grad<N, S>& a) {
  Grad<N, S> r;
  r.v = -a.v;
  for (int i = 0; i < N; ++i) r.d[i] = -a.d[i];
  return r;
}
template <int N, class S> inline Grad<N, S> operator*(const Grad<N, S>& a, const Grad<N, S>& b) {
  Grad<N, S> r;
  r.v = a.v * b.v;
  for (int i = 0; i < N; ++i) r.d[i] = a.d[i] * b.v + a.v * b.d[i];
  return r;
}
template <int N, class S> inline Grad<N, S> operator*(double a, const Grad<N, S>& b) {
  Grad<N, S> r;
  r.v = a * b.v;
  for (int i = 0; i < N; ++i) r.d[i] = a * b.d[i];
  return r;
}
template <int N, class S> inline Grad<N, S> operator*(const Grad<N, S>& a, double b) { return b * a; }
// A constant shifts the value only.
template <int N, class S> inline Grad<N, S> operator+(const Grad<N, S>& a, double b) {
  Grad<N, S> r = a;
  r.v = a.v + b;
  return r;
}
template <int N, class S> inline Grad<N, S> operator-(const Grad<N, S>& a, double b) {
  Grad<N, S> r = a;
  r.v = a.v - b;
  return r;
}
template <int N, class S> inline Grad<N, S> operator/(const Grad<N, S>& a, const Grad<N, S>& b) {
  const S ib = S(1.0) / b.v;
  Grad<N, S> r;
  r.v = a.v * ib;
  for (int i = 0; i < N; ++i) r.d[i] = (a.d[i] - r.v * b.d[i]) * ib;
  return r;
}
// f(a) with f' known: the chain rule.
template <int N, class S> inline Grad<N, S> chain(const Grad<N, S>& a, const S& f, const S& df) {
  Grad<N, S> r;
  r.v = f;
  for (int i = 0; i < N; ++i) r.d[i] = df * a.d[i];
  return r;
}
template <int N, class S> inline Grad<N, S> sqrt(const Grad<N, S>& a) {
  using std::sqrt;
  const S s = sqrt(a.v);
  return chain(a, s, S(0.5) / s);
}
// sin and cos together (one pair of library calls for the value).
template <int N, class S> inline void sin_cos(const Grad<N, S>& a, Grad<N, S>& s, Grad<N, S>& c) {
  using std::cos;
  using std::sin;
  const S sv = sin(a.v), cv = cos(a.v);
  s = chain(a, sv, cv);
  c = chain(a, cv, S(-sv));
}
template <int N, class S> inline Grad<N, S> sin(const Grad<N, S>& a) {
  using std::cos;
  using std::sin;
  return chain(a, S(sin(a.v)), S(cos(a.v)));
}
template <int N, class S> inline Grad<N, S> cos(const Grad<N, S>& a) {
  using std::cos;
  using std::sin;
  return chain(a, S(cos(a.v)), S(-sin(a.v)));
}
template <int N, class S> inline Grad<N, S> acos(const Grad<N, S>& a) {
  using std::acos;
  using std::sqrt;
  return chain(a, S(acos(a.v)), S(S(-1.0) / sqrt(S(1.0) - a.v * a.v)));
}
template <int N, class S> inline Grad<N, S> atan2(const Grad<N, S>& y, const Grad<N, S>& x) {
  using std::atan2;
  const S r2 = x.v * x.v + y.v * y.v;
  Grad<N, S> r;
  r.v = atan2(y.v, x.v);
  for (int i = 0; i < N; ++i) r.d[i] = (x.v * y.d[i] - y.v * x.d[i]) / r2;
  return r;
}

// Second-order Taylor coefficients along one path: v, d1 = dv/dt, d2 = d2v/dt2.
struct Taylor2 {
  double v, d1, d2;
  Taylor2() {}  // uninitialised, like a double
  Taylor2(double x) : v(x), d1(0), d2(0) {}  // NOLINT
  Taylor2(double x, double x1, double x2) : v(x), d1(x1), d2(x2) {}
};
inline Taylor2 operator+(const Taylor2& a, const Taylor2& b) { return {a.v + b.v, a.d1 + b.d1, a.d2 + b.d2}; }
inline Taylor2 operator-(const Taylor2& a, const Taylor2& b) { return {a.v - b.v, a.d1 - b.d1, a.d2 - b.d2}; }
inline Taylor2 operator-(const Taylor2& a) { return {-a.v, -a.d1, -a.d2}; }
inline Taylor2 operator*(const Taylor2& a, const Taylor2& b) {
  return {a.v * b.v, a.d1 * b.v + a.v * b.d1, a.d2 * b.v + 2 * a.d1 * b.d1 + a.v * b.d2};
}
inline Taylor2 operator*(double a, const Taylor2& b) { return {a * b.v, a * b.d1, a * b.d2}; }
inline Taylor2 operator/(const Taylor2& a, const Taylor2& b) {
  const double ib = 1.0 / b.v;
  const double r = a.v * ib;
  const double r1 = (a.d1 - r * b.d1) * ib;
  const double r2 = (a.d2 - 2 * r1 * b.d1 - r * b.d2) * ib;
  return {r, r1, r2};
}
// f(a) with f', f'' known: (f o a)'' = f'' a'^2 + f' a''.
inline Taylor2 chain(const Taylor2& a, double f, double df, double ddf) {
  return {f, df * a.d1, ddf * a.d1 * a.d1 + df * a.d2};
}
inline Taylor2 sqrt(const Taylor2& a) {
  const double s = std::sqrt(a.v);
  return chain(a, s, 0.5 / s, -0.25 / (s * a.v));
}
inline Taylor2 sin(const Taylor2& a) {
  const double s = std::sin(a.v), c = std::cos(a.v);
  return chain(a, s, c, -s);
}
inline Taylor2 cos(const Taylor2& a) {
  const double s = std::sin(a.v), c = std::cos(a.v);
  return chain(a, c, -s, -c);
}
inline void sin_cos(const Taylor2& a, Taylor2& s, Taylor2& c) {
  const double sv = std::sin(a.v), cv = std::cos(a.v);
  s = chain(a, sv, cv, -sv);
  c = chain(a, cv, -sv, -cv);
}
inline void sin_cos(double a, double& s, double& c) { sin_cos_small(a, s, c); }
inline Taylor2 acos(const Taylor2& a) {
  const double u = 1.0 - a.v * a.v;
  const double df = -1.0 / std::sqrt(u);
  return chain(a, std::acos(a.v), df, -a.v / (u * std::sqrt(u)));
}
inline Taylor2 atan2(const Taylor2& y, const Taylor2& x) {
  // theta = atan2(y, x): theta' = (x y' - y x') / r2, theta'' by the quotient rule.
  const double r2 = x.v * x.v + y.v * y.v;
  const double num1 = x.v * y.d1 - y.v * x.d1;
  const double t1 = num1 / r2;
  const double num2 = x.v * y.d2 - y.v * x.d2;  // derivative of num1 (the x' y' terms cancel)
  const double r2d = 2 * (x.v * x.d1 + y.v * y.d1);
  return {std::atan2(y.v, x.v), t1, (num2 - t1 * r2d) / r2};
}

inline double value_of(double a) { return a; }
inline double value_of(const Taylor2& a) { return a.v; }
template <int N, class S> inline double value_of(const Grad<N, S>& a) { return value_of(a.v); }

}  // namespace described
}  // namespace pkm
