// The planar four-bar linkage of Vitali 2020 (a calibration benchmark, one degree of freedom).
//
// Frame: origin at the fixed pivot A, x along the fixed link AD (D = (l4, 0)).  The crank
// AB (l1) is driven at angle theta; the coupler BC (l2) makes angle phi with x; the rocker
// DC (l3) closes the loop:  l1 e(theta) + l2 e(phi) = l4 e(0) + l3 e(psi)  (Vitali 2020 ch. 1.1).
// Output: X = l1 cos(theta) + l2/2 cos(phi), the x coordinate of the mid point of the
// coupler.  Pose x[1] = theta and joint q[1] = theta (the crank is the actuator).
//
// Loop closure for phi.  With u = B - D = (l1 cos(theta) - l4, l1 sin(theta)), the
// rocker length gives |u + l2 e(phi)| = l3, i.e.  u . e(phi) = k = (l3^2 - l2^2 - |u|^2)/(2 l2),
// so phi = atan2(u_y, u_x) - acos(k / |u|).  The minus sign is the assembly mode of the
// source (phi = 37.9585 deg at theta = 30 deg; the other mode gives phi = 245.5 deg).  This
// form replaces the source's tangent-half-angle quadratic, which divides by a coefficient
// that can vanish.  |k / |u|| > 1 means the links cannot be assembled at that theta.
//
// dX/dl by implicit differentiation of F(phi, l) = |w|^2 - l3^2 = 0, w = C - D = u + l2 e(phi):
//   dF/dphi = 2 l2 w . e'(phi),  dF/dl1 = 2 w . e(theta),  dF/dl2 = 2 w . e(phi),
//   dF/dl3 = -2 l3,  dF/dl4 = -2 w_x;   dphi/dl_j = -(dF/dl_j) / (dF/dphi),
//   dX/dl_j = [j=1] cos(theta) + [j=2] cos(phi)/2 - l2/2 sin(phi) dphi/dl_j.
// dF/dphi = 0 when coupler and rocker are aligned: the linkage is at a dead point there
// (direct singularity), reported as PKM_ERR_SINGULAR.
#include <cmath>
#include <sstream>

#include "common/guard.hpp"
#include "common/robot.hpp"

namespace pkm {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct FourbarModel final : RobotModel {
  double l[4];
  double home_theta;
};

// Configuration of the linkage at crank angle theta.
struct Config {
  double phi;
  double wx, wy;  // w = C - D, the rocker vector
  double sin_tr;  // sine of the angle between coupler and rocker (0 at a dead point)
};

std::string deg(double rad) {
  std::ostringstream os;
  os.precision(10);
  os << rad << " rad (" << rad * 180.0 / kPi << " deg)";
  return os.str();
}

// Returns false instead of throwing when the linkage cannot be assembled (used to scan).
bool try_assemble(const double* l, double theta, Config& c, double& ratio) {
  const double ux = l[0] * std::cos(theta) - l[3], uy = l[0] * std::sin(theta);
  const double rho = std::hypot(ux, uy);
  if (rho == 0.0) {
    ratio = INFINITY;
    return false;
  }
  const double k = (l[2] * l[2] - l[1] * l[1] - rho * rho) / (2.0 * l[1]);
  ratio = k / rho;
  if (!(std::fabs(ratio) <= 1.0)) return false;
  c.phi = std::atan2(uy, ux) - std::acos(ratio);
  c.wx = ux + l[1] * std::cos(c.phi);
  c.wy = uy + l[1] * std::sin(c.phi);
  // coupler direction e(phi) x rocker direction w / l3
  c.sin_tr = (std::cos(c.phi) * c.wy - std::sin(c.phi) * c.wx) / l[2];
  return true;
}

Config assemble(const double* l, double theta) {
  Config c;
  double ratio;
  if (!try_assemble(l, theta, c, ratio)) {
    std::ostringstream os;
    os.precision(6);
    os << "four-bar cannot be assembled at crank angle theta = " << deg(theta)
       << ": the rocker (l3) cannot reach the coupler (l2) from the crank tip";
    if (std::isfinite(ratio)) os << " (cos of the closure angle would be " << ratio << ")";
    else os << " (crank tip on the fixed pivot D)";
    throw Error(PKM_ERR_UNREACHABLE, os.str());
  }
  return c;
}

struct Fourbar final : Robot {
  const char* name() const override { return "fourbar"; }
  const char* title() const override { return "four-bar linkage (Vitali 2020), hand-written"; }
  int ndof() const override { return 1; }
  std::vector<const char*> features() const override { return {"fourbar_output"}; }
  const char* pose_name(int) const override { return "theta"; }  // the crank angle (pose = joint)
  const char* pose_unit(int) const override { return "rad"; }
  // A tracker measures the output point (pkm_fourbar_output), not the crank angle.
  int tracker_count() const override { return 1; }
  const char* tracker_name(int) const override { return "X"; }
  const char* tracker_unit(int) const override { return "m"; }

  std::vector<ParamSpec> param_specs(const std::string& set) const override {
    if (set != "default")
      throw Error(PKM_ERR_ARGUMENT, "robot 'fourbar' has no parameter set '" + set + "' (known: default)");
    // Vitali 2020 ch. 1.1 nominal lengths.
    return {
        {"link[1].l", "m", "crank AB length l1 (driven at angle theta about A)", 0.600, 1e-6, 1e3},
        {"link[2].l", "m", "coupler BC length l2 (output point at its mid point)", 0.750, 1e-6, 1e3},
        {"link[3].l", "m", "rocker DC length l3", 0.790, 1e-6, 1e3},
        {"link[4].l", "m", "fixed link AD length l4 (along x)", 0.900, 1e-6, 1e3},
    };
  }

  std::unique_ptr<RobotModel> compile(const std::vector<ParamSpec>& specs,
                                      const std::vector<double>& v) const override {
    auto m = std::make_unique<FourbarModel>();
    for (int i = 0; i < 4; ++i) m->l[i] = v[i];
    // A closed quadrilateral needs its longest side shorter than the sum of the others.
    double sum = 0, longest = 0;
    int il = 0;
    for (int i = 0; i < 4; ++i) {
      sum += v[i];
      if (v[i] > longest) longest = v[i], il = i;
    }
    if (!(longest < sum - longest)) {
      std::ostringstream os;
      os.precision(10);
      os << "four-bar cannot close for any crank angle: " << specs[il].name << " = " << longest
         << " m is not shorter than the sum of the other three links (" << sum - longest << " m)";
      throw Error(PKM_ERR_PARAMETER, os.str());
    }
    // Home: the source's first measurement angle (30 deg) if the linkage assembles there,
    // otherwise the middle of the first assemblable interval of a 0.1 deg scan.
    Config c;
    double ratio;
    const double source_home = 30.0 * kPi / 180.0;
    if (try_assemble(m->l, source_home, c, ratio) && std::fabs(c.sin_tr) > 1e-6) {
      m->home_theta = source_home;
    } else {
      int first = -1, last = -1;
      for (int k = 0; k < 3600; ++k) {
        const double th = -kPi + k * (2 * kPi / 3600);
        const bool ok = try_assemble(m->l, th, c, ratio) && std::fabs(c.sin_tr) > 1e-6;
        if (ok && first < 0) first = k;
        if (ok) last = k;
        if (!ok && first >= 0) break;
      }
      if (first < 0)
        throw Error(PKM_ERR_PARAMETER,
                    "four-bar link lengths (link[1..4].l) admit no assemblable, non-singular crank angle");
      m->home_theta = -kPi + 0.5 * (first + last) * (2 * kPi / 3600);
    }
    return m;
  }

  void home(const RobotModel& rm, double* x) const override {
    x[0] = static_cast<const FourbarModel&>(rm).home_theta;
  }

  void ik(const RobotModel& rm, RobotData&, const double* x, double* q) const override {
    assemble(static_cast<const FourbarModel&>(rm).l, x[0]);
    q[0] = x[0];
  }

  void fk(const RobotModel& rm, RobotData&, const double* q, const double*, const pkm_fk_options&,
          double* x, pkm_fk_info& info) const override {
    assemble(static_cast<const FourbarModel&>(rm).l, q[0]);
    x[0] = q[0];
    info.iterations = 0;
    info.residual = 0.0;
  }

  void jacobians(const RobotModel& rm, RobotData&, const double* x, double* Jx, double* Jq,
                 double* J) const override {
    assemble(static_cast<const FourbarModel&>(rm).l, x[0]);
    if (Jx) Jx[0] = 1.0;
    if (Jq) Jq[0] = 1.0;
    if (J) J[0] = 1.0;
  }

  void jacobian_dot(const RobotModel& rm, RobotData&, const double* x, const double*,
                    double* Jdot) const override {
    assemble(static_cast<const FourbarModel&>(rm).l, x[0]);
    Jdot[0] = 0.0;
  }

  // measures[0]: the crank drives theta directly, so no inverse-kinematic singularity;
  // measures[1]: |sin| of the coupler-rocker angle, 0 at a dead point.
  void singularity(const RobotModel& rm, RobotData&, const double* x, double* measures) const override {
    const Config c = assemble(static_cast<const FourbarModel&>(rm).l, x[0]);
    measures[0] = 1.0;
    measures[1] = std::fabs(c.sin_tr);
  }
};

}  // namespace

const Robot* robot_fourbar() {
  static Fourbar r;
  return &r;
}

}  // namespace pkm

extern "C" int pkm_fourbar_output(const pkm_model* m, pkm_data* d, double theta, double* X, double* dX_dl) {
  using namespace pkm;
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    PKM_REQUIRE(m->robot_name == "fourbar", PKM_ERR_ARGUMENT,
            "pkm_fourbar_output needs a 'fourbar' model, got a '" + m->robot_name + "' model");
    check_finite(&theta, 1, "crank angle theta");
    check_out(X, "X");
    const double* l = static_cast<const FourbarModel&>(rm).l;
    const Config c = assemble(l, theta);
    const double cphi = std::cos(c.phi), sphi = std::sin(c.phi);
    if (dX_dl) {
      const double dF_dphi = 2.0 * l[1] * (-sphi * c.wx + cphi * c.wy);
      // Relative to the sizes involved, a vanishing dF/dphi is a dead point.
      if (!(std::fabs(dF_dphi) > 1e-12 * 2.0 * l[1] * l[2])) {
        std::ostringstream os;
        os << "four-bar at a dead point (coupler and rocker aligned) at crank angle theta = " << deg(theta)
           << ": dX/dl is unbounded";
        throw Error(PKM_ERR_SINGULAR, os.str());
      }
      const double dF[4] = {2.0 * (c.wx * std::cos(theta) + c.wy * std::sin(theta)),
                            2.0 * (c.wx * cphi + c.wy * sphi), -2.0 * l[2], -2.0 * c.wx};
      for (int j = 0; j < 4; ++j) {
        const double dphi = -dF[j] / dF_dphi;
        dX_dl[j] = -0.5 * l[1] * sphi * dphi;
      }
      dX_dl[0] += std::cos(theta);
      dX_dl[1] += 0.5 * cphi;
    }
    *X = l[0] * std::cos(theta) + 0.5 * l[1] * cphi;
  });
}
