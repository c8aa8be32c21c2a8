// The hand-written 6-PUS (Tiberi 2020 and Zavala-Yoe et al. 2015), kept as a test oracle of the
// described robot "6pus" (robots/6pus.toml) under the name "6pus_hand": private interface shared
// by sixpus.cpp (parameters, compile, registration), sixpus_kinematics.cpp and
// sixpus_dynamics.cpp.  See docs/6pus.md for the equations and conventions.
//
// Notation (all in the world frame unless said otherwise):
//   pose x = (p, a), p = (x, y, z), a = (rx, ry, rz), R = Rx(rx) Ry(ry) Rz(rz)
//   omega = E(a) a_dot                          (platform angular velocity)
//   leg i: rP = R p_i,  P = p + rP,  S = S0 + q s,  w = P - S,  |w| = L,  c = s.w
//   twist nu = (p_dot, omega) = T xd,  T = blockdiag(I, E)
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <string>

#include "common/fast_math.hpp"
#include "common/robot.hpp"

namespace pkm {
namespace sixpus {

using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;
using V6 = Eigen::Matrix<double, 6, 1>;
using M6 = Eigen::Matrix<double, 6, 6>;
using M6r = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;

constexpr int NLEG = 6;

struct Model final : RobotModel {
  V3 p_local[NLEG];  // platform attachment points in the platform frame [m]
  V3 S0[NLEG];       // slider position at q = 0 [m]
  V3 s[NLEG];        // rail directions (unit within 1e-6, used as given) [1]
  double ss[NLEG];   // s.s
  double L[NLEG];
  double branch[NLEG];  // +1: slider on the -s side of P (s.w > 0), -1: on the +s side
  double m_leg[NLEG], m_slider[NLEG];
  double qmin[NLEG], qmax[NLEG];
  double m_platform;
  V3 I_platform;  // principal moments about the platform frame origin (= its CoM) [kg m2]
  double m_payload;
  V3 c_payload;  // payload offset in the platform frame [m]
  V3 g;          // gravity [m/s2]
  double r_char;  // mean |p_i|: length scale of the rotation columns in measures[1] [m]
  double home[6];
  double inv_ss[NLEG];    // 1 / s.s
  double disc_tol[NLEG];  // a leg is perpendicular to its rail when (s.w)^2 < disc_tol
  // The same geometry as plain arrays over the legs, for the vectorised IK hot path.
  struct {
    double px[NLEG], py[NLEG], pz[NLEG], S0x[NLEG], S0y[NLEG], S0z[NLEG], sx[NLEG], sy[NLEG], sz[NLEG];
    double ss[NLEG], L2[NLEG];
  } soa;
};

// Position-level state of one leg at a pose.
struct Leg {
  V3 rP;     // R p_i
  V3 w;      // P - S
  double q;  // stroke
  double c;  // s.w
};

// Rotation and angular-velocity map of a pose.
struct Frame {
  M3 R;
  M3 E;  // omega = E a_dot
  double sx, cx, sy, cy;
};

inline void frame_of(const double* x, Frame& f) {
  double sx, cx, sy, cy, sz, cz;
  sin_cos_small(x[3], sx, cx);
  sin_cos_small(x[4], sy, cy);
  sin_cos_small(x[5], sz, cz);
  f.sx = sx, f.cx = cx, f.sy = sy, f.cy = cy;
  f.R << cy * cz, -cy * sz, sy,                       //
      sx * sy * cz + cx * sz, -sx * sy * sz + cx * cz, -sx * cy,  //
      -cx * sy * cz + sx * sz, cx * sy * sz + sx * cz, cx * cy;
  f.E << 1, 0, sy,  //
      0, cx, -sx * cy,  //
      0, sx, cx * cy;
}

// dE/dt for the Euler-angle rates ad.
inline M3 Edot_of(const Frame& f, const double* ad) {
  M3 Ed;
  Ed << 0, 0, f.cy * ad[1],  //
      0, -f.sx * ad[0], -f.cx * f.cy * ad[0] + f.sx * f.sy * ad[1],  //
      0, f.cx * ad[0], -f.sx * f.cy * ad[0] - f.cx * f.sy * ad[1];
  return Ed;
}

// How strictly inverse kinematics treats a leg.
enum class Strokes { check, ignore };

// Closed-form inverse kinematics of every leg (Tiberi 2020 eq. 2.17a/b).  Throws
// PKM_ERR_UNREACHABLE / PKM_ERR_SINGULAR naming the leg and the pose, and with
// Strokes::check PKM_ERR_JOINT_LIMIT naming the leg and the stroke.
void legs_at(const Model& m, const double* x, const Frame& f, Leg* legs, Strokes strokes);

// Vector from the rail origin to the platform point, d = p + R p_i - S0, and R p_i;
// written out so that every caller gets the same bits.
inline void leg_vectors(const Model& m, int i, const double* x, const M3& R, V3& rP, V3& d) {
  const V3& pl = m.p_local[i];
  for (int k = 0; k < 3; ++k) {
    rP[k] = R(k, 0) * pl[0] + R(k, 1) * pl[1] + R(k, 2) * pl[2];
    d[k] = (x[k] + rP[k]) - m.S0[i][k];
  }
}

// Pose as text for error messages.
std::string pose_text(const double* x);

// Twist-space Jacobian rows: qd_i = jt_i . nu with jt_i = (w, rP x w) / c.
inline V6 twist_row(const Leg& l) {
  V6 j;
  const double ic = 1.0 / l.c;
  j.head<3>() = ic * l.w;
  j.tail<3>() = ic * l.rP.cross(l.w);
  return j;
}

// Leg velocities at (x, xd): P_dot, qd, w_dot.
struct LegRates {
  V3 Pd, wd;
  double qd;
};
inline void leg_rates(const Model& m, int i, const Leg& l, const V3& pd, const V3& om, LegRates& r) {
  r.Pd = pd + om.cross(l.rP);
  r.qd = l.w.dot(r.Pd) / l.c;
  r.wd = r.Pd - r.qd * m.s[i];
}

const Model& model_of(const RobotModel& rm);

class SixPus final : public Robot {
 public:
  const char* name() const override { return "6pus_hand"; }
  const char* title() const override { return "6-PUS laser-cutting platform (Tiberi 2020; Zavala-Yoe et al. 2015), hand-written test oracle"; }
  int ndof() const override { return 6; }
  std::vector<ParamSpec> param_specs(const std::string& set) const override;
  std::unique_ptr<RobotModel> compile(const std::vector<ParamSpec>& specs,
                                      const std::vector<double>& values) const override;
  void home(const RobotModel&, double* x) const override;
  // Rail friction, rotor inertia and the sensor model are the drive layer's
  // (dynamics/drive.hpp): its parameters are "rail[i].coulomb", "rail[i].viscous", ...
  const char* joint_prefix() const override { return "rail"; }
  const char* joint_noun() const override { return "slider"; }
  bool joints_angular() const override { return false; }
  const char* limb_noun() const override { return "leg"; }
  const char* pose_name(int i) const override {
    static const char* n[] = {"x", "y", "z", "rx", "ry", "rz"};
    return n[i];
  }
  const char* pose_unit(int i) const override { return i < 3 ? "m" : "rad"; }
  std::string joint_limit_param(int i, bool upper) const override {
    return "rail[" + std::to_string(i + 1) + (upper ? "].qmax" : "].qmin");
  }
  // A geometric error is a leg-length error, leg by leg (Tiberi 2020: the rod lengths are
  // the parameters a rebuild most often gets wrong).
  const char* geometry_param(int i) const override {
    static const char* n[] = {"leg[1].L", "leg[2].L", "leg[3].L", "leg[4].L", "leg[5].L", "leg[6].L"};
    return i >= 0 && i < 6 ? n[i] : nullptr;
  }

  void ik(const RobotModel&, RobotData&, const double* x, double* q) const override;
  void jacobians(const RobotModel&, RobotData&, const double* x, double* Jx, double* Jq,
                 double* J) const override;
  void jacobian_dot(const RobotModel&, RobotData&, const double* x, const double* xd,
                    double* Jdot) const override;
  void singularity(const RobotModel&, RobotData&, const double* x, double* measures) const override;
  void chain_points(const RobotModel&, RobotData&, const double* x, double* pts) const override;
  // The pose is the platform's full pose (p, rx, ry, rz): X = x, S = I.
  void platform_pose(const RobotModel&, RobotData&, const double* x, double* X, double* S) const override;
  bool has_platform() const override { return true; }
  void direct_singularity_guard(const RobotModel&, RobotData&, const double* x, double* measure_bound,
                                double* det_j) const override;
  void fk(const RobotModel&, RobotData&, const double* q, const double* x_guess,
          const pkm_fk_options& opt, double* x, pkm_fk_info& info) const override;
  void joint_acceleration(const RobotModel&, RobotData&, const double* x, const double* xd,
                          const double* xdd, double* qdd) const override;

  void inverse_dynamics(const RobotModel&, RobotData&, const double* x, const double* xd,
                        const double* xdd, double* tau) const override;
  void mass_matrix(const RobotModel&, RobotData&, const double* x, double* M) const override;
  void forward_dynamics(const RobotModel&, RobotData&, const double* x, const double* xd,
                        const double* tau, double* xdd) const override;
  void energy(const RobotModel&, RobotData&, const double* x, const double* xd, double* kinetic,
              double* potential) const override;
  bool forward_dynamics_response(const RobotModel&, RobotData&, const double* x, const double* xd,
                                 const double* tau, double* xdd, double* B) const override;
};

// J = Jq^-1 Jx (row-major) and measures; shared by singularity() and compile().
void jacobian_of(const Model& m, const Frame& f, const Leg* legs, M6r& J);
void singularity_measures(const Model& m, const Frame& f, const Leg* legs, double* measures);

}  // namespace sixpus
}  // namespace pkm
