// The 6-PUS specific C functions (pkm.h: calibration rows, leg points) on the described 6-PUS:
// the legs' points come from the robot's chain_points (the description's closed-form leg
// geometry, strokes not checked: the regression rows exist outside the stroke range too,
// source 000 pose 7 has a negative stroke for leg 1), the parameters from its compiled model.
#include "robots/sixpus_facts.hpp"

#include <Eigen/Dense>

#include "common/guard.hpp"
#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"

namespace pkm {
namespace sixpus {

namespace {

constexpr int kLegs = 6;

const described::DescribedRobot* as_described(const Robot& r) { return dynamic_cast<const described::DescribedRobot*>(&r); }

// The compiled model of (m, d), which must be a 6-PUS.
const described::Model& model_6pus(const pkm_model* m, pkm_data* d) {
  const RobotModel& rm = prepare(m, d);
  if (!is_6pus(*m->robot))
    throw Error(PKM_ERR_UNSUPPORTED, "this function is for the 6pus robot (six PUS legs over the whole pose), not '" +
                                         m->robot_name + "'");
  return static_cast<const described::Model&>(rm);
}

// Each leg's rail origin S0, slider S and platform joint P at pose x (pts[6][3][3]).
void leg_chain(const pkm_model* m, pkm_data* d, const double* x, double* pts) {
  d->robot->chain_points(prepare(m, d), *d->rd, x, pts);
}

}  // namespace

bool is_6pus(const Robot& r) {
  const described::DescribedRobot* dr = as_described(r);
  if (!dr) return false;
  const described::Description& desc = dr->description();
  if (desc.structure != described::Structure::legs || desc.articulated || desc.point || !desc.dependent.empty() ||
      desc.coords != std::vector<int>{0, 1, 2, 3, 4, 5} || desc.legs.size() != kLegs)
    return false;
  // Every leg a slider on a rail and a rod to its platform point (its kind's traits): the
  // geometry the rows differentiate, |P - S0 - q s| = L.
  for (const described::LegType* t : desc.legs) {
    const described::LegMotion& k = t->leg->motion();
    if (k.angular() || !k.has_rod()) return false;
  }
  return true;
}

}  // namespace sixpus
}  // namespace pkm

using namespace pkm;
using V3 = Eigen::Vector3d;

extern "C" {

int pkm_6pus_calib_rows(const pkm_model* m, pkm_data* d, const double* x, int frame, double* rows) {
  return guard(d, [&] {
    const described::Model& sm = sixpus::model_6pus(m, d);
    check_finite(x, 6, "pose x");
    check_out(rows, "rows");
    PKM_REQUIRE(frame == PKM_FRAME_WORLD || frame == PKM_FRAME_PLATFORM, PKM_ERR_ARGUMENT,
                "frame = " + std::to_string(frame) + " must be PKM_FRAME_WORLD (0) or PKM_FRAME_PLATFORM (1)");
    double pts[sixpus::kLegs * 9];
    sixpus::leg_chain(m, d, x, pts);
    // R = Rx(rx) Ry(ry) Rz(rz) (pkm.h's pose convention).
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(x[3], V3::UnitX()) * Eigen::AngleAxisd(x[4], V3::UnitY()) *
                               Eigen::AngleAxisd(x[5], V3::UnitZ()))
                                  .toRotationMatrix();
    for (int i = 0; i < sixpus::kLegs; ++i) {
      const described::LegModel& l = sm.legs[(size_t)i];
      const V3 S(pts + 9 * i + 3), P(pts + 9 * i + 6);
      const V3 w = P - S;
      const double c = l.dir.dot(w), q = l.dir.dot(S - l.base) * l.inv_ss;
      double* r = rows + 10 * i;
      // Implicit derivatives of |P - S0 - q s|^2 = L^2 (Tiberi 2020 eq. 4.9) with respect to
      // the platform point, S0, L and s.
      V3 dP = w / c;
      if (frame == PKM_FRAME_PLATFORM) dP = R.transpose() * dP;  // dq/dp_local = dq/dP R
      for (int k = 0; k < 3; ++k) {
        r[k] = dP[k];
        r[3 + k] = -w[k] / c;
        r[7 + k] = -q * w[k] / c;
      }
      r[6] = -l.L / c;
    }
  });
}

int pkm_6pus_leg_points(const pkm_model* m, pkm_data* d, const double* x, double* P, double* S) {
  return guard(d, [&] {
    sixpus::model_6pus(m, d);
    check_finite(x, 6, "pose x");
    check_out(P, "P");
    check_out(S, "S");
    double pts[sixpus::kLegs * 9];
    sixpus::leg_chain(m, d, x, pts);
    for (int i = 0; i < sixpus::kLegs; ++i)
      for (int k = 0; k < 3; ++k) {
        S[3 * i + k] = pts[9 * i + 3 + k];
        P[3 * i + k] = pts[9 * i + 6 + k];
      }
  });
}

}  // extern "C"
