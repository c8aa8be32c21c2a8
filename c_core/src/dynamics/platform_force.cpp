// The force on the platform (see platform_force.hpp).
#include "dynamics/platform_force.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <string>

#include "common/guard.hpp"
#include "common/param_lookup.hpp"

namespace pkm {
namespace platform_force {

namespace {
const char* const kAxes[3] = {"x", "y", "z"};
using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;
using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, 6, 6>;
using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 6, 1>;

// R = Rx(rx) Ry(ry) Rz(rz) and E (w = E (rx, ry, rz)_dot) of the full pose X.
void rotation(const double* X, M3& R, M3& E) {
  const double sx = std::sin(X[3]), cx = std::cos(X[3]), sy = std::sin(X[4]), cy = std::cos(X[4]);
  const double sz = std::sin(X[5]), cz = std::cos(X[5]);
  R << cy * cz, -(cy * sz), sy, sx * sy * cz + cx * sz, cx * cz - sx * sy * sz, -(sx * cy), sx * sz - cx * sy * cz,
      cx * sy * sz + sx * cz, cx * cy;
  E << 1, 0, sy, 0, cx, -sx * cy, 0, sx, cx * cy;
}
}  // namespace

std::vector<ParamSpec> specs(const Robot& r) {
  std::vector<ParamSpec> out;
  if (!r.has_platform()) return out;
  const double big = 1e12;
  const std::string on = " on the platform (world frame)";
  for (int k = 0; k < 3; ++k)
    out.push_back({std::string("wrench.f") + kAxes[k], "N", std::string("constant force along ") + kAxes[k] + on, 0.0,
                   -big, big});
  for (int k = 0; k < 3; ++k)
    out.push_back({std::string("wrench.m") + kAxes[k], "N m",
                   std::string("constant moment about ") + kAxes[k] + on + ", about the pose's reference point", 0.0,
                   -big, big});
  for (int k = 0; k < 3; ++k)
    out.push_back({std::string("cable.anchor_") + kAxes[k], "m",
                   std::string(kAxes[k]) + " of the fixed anchor a cable or spring pulls the platform towards (world)",
                   0.0, -big, big});
  for (int k = 0; k < 3; ++k)
    out.push_back({std::string("cable.point_") + kAxes[k], "m",
                   std::string(kAxes[k]) + " of the platform point the cable is tied to (platform frame of the full "
                                           "pose, from its reference point)",
                   0.0, -big, big});
  out.push_back({"cable.tension", "N",
                 "cable tension at its rest length, pulling the platform point towards the anchor (0: no cable)", 0.0,
                 -big, big});
  out.push_back({"cable.stiffness", "N/m", "cable stiffness: tension added per metre beyond the rest length", 0.0, 0.0,
                 big});
  out.push_back({"cable.rest_length", "m", "the cable's length at which its tension is cable.tension", 0.0, 0.0, big});
  out.push_back({"platform_drag.linear", "N s/m", "drag on the platform: force per unit of its reference point's "
                                                  "velocity, opposing it",
                 0.0, -big, big});
  out.push_back({"platform_drag.angular", "N m s/rad",
                 "rotational drag on the platform: moment per unit of its angular velocity, opposing it", 0.0, -big,
                 big});
  return out;
}

Params compile(const Robot& r, const std::vector<ParamSpec>& sp, const std::vector<double>& values) {
  Params p;
  if (!r.has_platform()) return p;
  InOrderLookup table(sp, values);
  auto get = [&](const std::string& name) -> double {
    if (const double* v = table.find(name)) return *v;
    throw Error(PKM_ERR_INTERNAL, "platform force parameter " + name + " missing from the table");
  };
  for (int k = 0; k < 3; ++k) {
    p.force[k] = get(std::string("wrench.f") + kAxes[k]);
    p.moment[k] = get(std::string("wrench.m") + kAxes[k]);
    p.anchor[k] = get(std::string("cable.anchor_") + kAxes[k]);
    p.point[k] = get(std::string("cable.point_") + kAxes[k]);
    p.any |= p.force[k] != 0 || p.moment[k] != 0;
  }
  p.tension = get("cable.tension");
  p.stiffness = get("cable.stiffness");
  p.rest_length = get("cable.rest_length");
  p.drag_linear = get("platform_drag.linear");
  p.drag_angular = get("platform_drag.angular");
  p.any |= p.tension != 0 || p.stiffness != 0 || p.drag_linear != 0 || p.drag_angular != 0;
  return p;
}

namespace {
// The wrench at the full pose X and its rate Xd (nullptr: at rest); E the angle map of X.
void wrench_at(const Params& p, const double* X, const double* Xd, const M3& R, const M3& E, double* w) {
  V3 f = Eigen::Map<const V3>(p.force), mom = Eigen::Map<const V3>(p.moment);
  if (p.tension != 0 || p.stiffness != 0) {
    const V3 rP = R * Eigen::Map<const V3>(p.point);
    const V3 to = Eigen::Map<const V3>(p.anchor) - (Eigen::Map<const V3>(X) + rP);
    const double L = to.norm();
    if (!(L > 1e-9))
      throw Error(PKM_ERR_ARGUMENT, "the cable's platform point (cable.point_*) reaches its anchor (cable.anchor_*) "
                                    "at this pose: the cable has no direction");
    const V3 fc = (p.tension + p.stiffness * (L - p.rest_length)) / L * to;
    f += fc;
    mom += rP.cross(fc);
  }
  if (Xd) {
    f -= p.drag_linear * Eigen::Map<const V3>(Xd);
    mom -= p.drag_angular * (E * Eigen::Map<const V3>(Xd + 3));
  }
  Eigen::Map<V3> wf(w), wm(w + 3);
  wf = f;
  wm = mom;
}

// The full pose X, its rate Xd = S xd (when xd), the motion map S[6, n], R and E at x.
void motion(const pkm_model* m, pkm_data* d, const double* x, const double* xd, double* X, double* Xd, double* S,
            M3& R, M3& E) {
  const int n = d->ndof;
  m->robot->platform_pose(*m->compiled, *d->rd, x, X, S);
  rotation(X, R, E);
  if (!xd) return;
  for (int r = 0; r < 6; ++r) {
    Xd[r] = 0;
    for (int j = 0; j < n; ++j) Xd[r] += S[r * n + j] * xd[j];
  }
}
}  // namespace

void wrench(const pkm_model* m, pkm_data* d, const Params& p, const double* x, const double* xd, double* w) {
  double X[6], Xd[6], S[36];
  M3 R, E;
  motion(m, d, x, xd, X, Xd, S, R, E);
  wrench_at(p, X, xd ? Xd : nullptr, R, E, w);
}

void add(const pkm_model* m, pkm_data* d, const Params& p, const double* x, const double* xd, double sign,
         double* out) {
  if (!p.any) return;
  const int n = d->ndof;
  double X[6], Xd[6], S[36], w[6], J[36];
  M3 R, E;
  motion(m, d, x, xd, X, Xd, S, R, E);
  wrench_at(p, X, xd ? Xd : nullptr, R, E, w);
  // Q = S' [f; E' m]: the power f.v + m.w = Q.xd
  double g[6];
  Eigen::Map<V3> gf(g), gm(g + 3);
  gf = Eigen::Map<const V3>(w);
  gm = E.transpose() * Eigen::Map<const V3>(w + 3);
  Vec Q(n);
  for (int j = 0; j < n; ++j) {
    Q[j] = 0;
    for (int r = 0; r < 6; ++r) Q[j] += S[r * n + j] * g[r];
  }
  // The drive's efforts F with J' F = -Q (their power F.qd = -Q.xd cancels the wrench's).
  m->robot->jacobians(*m->compiled, *d->rd, x, nullptr, nullptr, J);
  Eigen::PartialPivLU<Mat> lu(Eigen::Map<const Mat>(J, n, n).transpose());
  const auto diag = lu.matrixLU().diagonal().cwiseAbs();
  if (!(diag.minCoeff() > 1e-14 * diag.maxCoeff()))
    throw Error(PKM_ERR_SINGULAR, "the platform force: the Jacobian is singular at this pose (no joint efforts "
                                  "hold a wrench there)");
  const Vec F = lu.solve(-Q);
  for (int i = 0; i < n; ++i) out[i] += sign * F[i];
}

}  // namespace platform_force
}  // namespace pkm
