// A toy robot of the test build only (libpkm_toy.so): a vertical slider-crank, one degree of
// freedom.  It exists to prove that a new robot touches the core and nothing in Python: the
// Python package, the CLI, scenarios, calibration and the discrepancy engine must take it
// from the core's facts alone (tests/core/test_toy_robot.py).
//
// The crank (radius r, inertia I about its pivot at the origin) turns by theta, measured from
// the vertical; the massless rod (length l) joins the crank pin B = r (sin theta, cos theta)
// to the slider C = (0, z), which carries the mass m on the vertical axis, under gravity g_z.
// Pose x = z (the slider height), joint q = theta (the driven crank).
//   Closure  F(z, theta) = z^2 - 2 r z cos theta + r^2 - l^2 = 0
//   =>  Jx zd = Jq thetad with Jx = z - r cos theta, Jq = -r z sin theta; J = Jx / Jq.
//   IK (branch theta in (0, pi), the crank to the right of the axis): cos theta = (z^2 + r^2 - l^2) / (2 r z).
//   Kinetic energy (m + I J^2) zd^2 / 2 = M(z) zd^2 / 2; potential -m g_z z.
//   Lagrange: J tau = M zdd + I J J' zd^2 - m g_z, with J' = dJ/dz along the closure.
#include <cmath>
#include <sstream>

#include "common/robot.hpp"

namespace pkm {
namespace {

struct SliderCrankModel final : RobotModel {
  double r, l, m, I, gz;
};

struct Config {
  double c, s, J, dJ;  // cos and sin of theta, J = dtheta/dz, dJ/dz
};

Config config(const SliderCrankModel& p, double z) {
  const double c = (z * z + p.r * p.r - p.l * p.l) / (2 * p.r * z);
  if (!(z > 0) || !(std::fabs(c) < 1.0)) {
    std::ostringstream os;
    os.precision(6);
    os << "slider-crank: slider height z = " << z << " m is out of reach (the rod of " << p.l
       << " m cannot join the crank of " << p.r << " m to it: cos theta would be " << c << ")";
    throw Error(PKM_ERR_UNREACHABLE, os.str());
  }
  Config k;
  k.c = c;
  k.s = std::sqrt(1 - c * c);
  const double jx = z - p.r * k.c, jq = -p.r * z * k.s;
  k.J = jx / jq;
  // d(jx)/dz = 1 + r s J,  d(jq)/dz = -r s - r z c J
  const double djx = 1 + p.r * k.s * k.J, djq = -p.r * k.s - p.r * z * k.c * k.J;
  k.dJ = (djx * jq - jx * djq) / (jq * jq);
  return k;
}

struct SliderCrank final : Robot {
  const char* name() const override { return "slider_crank"; }
  int ndof() const override { return 1; }
  const char* pose_name(int) const override { return "z"; }
  const char* pose_unit(int) const override { return "m"; }
  const char* joint_noun() const override { return "crank"; }

  std::vector<ParamSpec> param_specs(const std::string& set) const override {
    if (set != "default")
      throw Error(PKM_ERR_ARGUMENT, "robot 'slider_crank' has no parameter set '" + set + "' (known: default)");
    return {
        {"crank.r", "m", "crank radius (pivot to crank pin)", 0.05, 1e-6, 10.0},
        {"rod.l", "m", "connecting rod length (crank pin to slider)", 0.15, 1e-6, 10.0},
        {"slider.m", "kg", "slider mass", 0.5, 1e-9, 1e6},
        {"crank.I", "kg m2", "crank inertia about its pivot", 2e-4, 1e-12, 1e6},
        {"gravity.z", "m/s2", "gravity acceleration along the slider axis", -9.81, -100, 100},
    };
  }

  std::unique_ptr<RobotModel> compile(const std::vector<ParamSpec>&, const std::vector<double>& v) const override {
    auto p = std::make_unique<SliderCrankModel>();
    p->r = v[0], p->l = v[1], p->m = v[2], p->I = v[3], p->gz = v[4];
    if (!(p->l > p->r))
      throw Error(PKM_ERR_PARAMETER, "slider-crank: rod.l must be longer than crank.r (the crank could not turn)");
    return p;
  }

  void home(const RobotModel& rm, double* x) const override {
    const auto& p = static_cast<const SliderCrankModel&>(rm);
    x[0] = std::sqrt(p.l * p.l - p.r * p.r);  // theta = 90 deg: the crank horizontal
  }

  void ik(const RobotModel& rm, RobotData&, const double* x, double* q) const override {
    const Config k = config(static_cast<const SliderCrankModel&>(rm), x[0]);
    q[0] = std::atan2(k.s, k.c);
  }

  void fk(const RobotModel& rm, RobotData&, const double* q, const double*, const pkm_fk_options&, double* x,
          pkm_fk_info& info) const override {
    const auto& p = static_cast<const SliderCrankModel&>(rm);
    const double s = std::sin(q[0]), c = std::cos(q[0]);
    if (!(s > 0))
      throw Error(PKM_ERR_UNREACHABLE, "slider-crank: crank angle outside (0, pi), the branch of this robot");
    x[0] = p.r * c + std::sqrt(p.l * p.l - p.r * p.r * s * s);
    info.iterations = 0;
    info.residual = 0.0;
  }

  void jacobians(const RobotModel& rm, RobotData&, const double* x, double* Jx, double* Jq,
                 double* J) const override {
    const auto& p = static_cast<const SliderCrankModel&>(rm);
    const Config k = config(p, x[0]);
    if (Jx) Jx[0] = x[0] - p.r * k.c;
    if (Jq) Jq[0] = -p.r * x[0] * k.s;
    if (J) J[0] = k.J;
  }

  void jacobian_dot(const RobotModel& rm, RobotData&, const double* x, const double* xd,
                    double* Jdot) const override {
    Jdot[0] = config(static_cast<const SliderCrankModel&>(rm), x[0]).dJ * xd[0];
  }

  // measures[0]: |sin theta| (0 at the dead centres, where the crank cannot move the slider);
  // measures[1]: |z - r cos theta| / l, the rod's lean off the horizontal (0 when it is
  // horizontal: the crank then cannot hold the slider).
  void singularity(const RobotModel& rm, RobotData&, const double* x, double* measures) const override {
    const auto& p = static_cast<const SliderCrankModel&>(rm);
    const Config k = config(p, x[0]);
    measures[0] = k.s;
    measures[1] = std::fabs(x[0] - p.r * k.c) / p.l;
  }

  void mass_matrix(const RobotModel& rm, RobotData&, const double* x, double* M) const override {
    const auto& p = static_cast<const SliderCrankModel&>(rm);
    const Config k = config(p, x[0]);
    M[0] = p.m + p.I * k.J * k.J;
  }

  void inverse_dynamics(const RobotModel& rm, RobotData&, const double* x, const double* xd, const double* xdd,
                        double* tau) const override {
    const auto& p = static_cast<const SliderCrankModel&>(rm);
    const Config k = config(p, x[0]);
    const double f = (p.m + p.I * k.J * k.J) * xdd[0] + p.I * k.J * k.dJ * xd[0] * xd[0] - p.m * p.gz;
    tau[0] = f / k.J;
  }

  void energy(const RobotModel& rm, RobotData&, const double* x, const double* xd, double* kinetic,
              double* potential) const override {
    const auto& p = static_cast<const SliderCrankModel&>(rm);
    const Config k = config(p, x[0]);
    *kinetic = 0.5 * (p.m + p.I * k.J * k.J) * xd[0] * xd[0];
    *potential = -p.m * p.gz * x[0];
  }
};

}  // namespace

// The registry's hook for robots of a test build (robots/registry.cpp).
int test_robot_count() { return 1; }
const Robot* test_robot_at(int) {
  static SliderCrank r;
  return &r;
}

}  // namespace pkm
