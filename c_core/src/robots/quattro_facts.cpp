// The Quattro specific C functions (pkm.h: indices, GIMRE, joint points) on the described
// Quattro (quattro_facts.hpp): the kinematics, mass matrix and inverse dynamics are the
// described robot's own (with the drive layer's rotor inertia, without its friction); the
// GIMRE is the source's formula (Virzi 2010 ch. 4.4.2) over the description's bodies.
#include "robots/quattro_facts.hpp"

#include <cmath>
#include <string>

#include "common/guard.hpp"
#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"
#include "dynamics/drive.hpp"

namespace pkm {
namespace quattro_facts {

namespace {

using V3 = Eigen::Vector3d;
using M4 = Eigen::Matrix4d;
using V4 = Eigen::Vector4d;
using RowM4 = Eigen::Matrix<double, 4, 4, Eigen::RowMajor>;

const described::DescribedRobot* as_described(const Robot& r) {
  return dynamic_cast<const described::DescribedRobot*>(&r);
}

const described::Model& model_of(const pkm_model* m, pkm_data* d) {
  return static_cast<const described::Model&>(prepare(m, d));
}

// Arm i's link length: the axis-to-elbow distance r measured along the arm's own line (the
// line of its centre of mass), r cos(com angle): the source's b_r, which normalises J.
double link_length(const described::LegModel& l) { return l.r * l.com_c; }

// J (row-major in Eigen's default column-major copy) at x; the IK checks reach and strokes.
M4 jacobian(const pkm_model* m, pkm_data* d, const double* x) {
  RowM4 J;
  d->robot->jacobians(*m->compiled, *d->rd, x, nullptr, nullptr, J.data());
  return J;
}

// y = J^-T f; throws PKM_ERR_SINGULAR at a direct (parallel) singularity.
V4 solve_jt(const M4& J, const V4& f, const char* what) {
  Eigen::PartialPivLU<M4> lu(J.transpose());
  if (!(lu.rcond() > 1e-12))
    throw Error(PKM_ERR_SINGULAR, std::string(what) + ": direct (parallel) singularity, J is singular at this pose (rcond " +
                                      std::to_string(lu.rcond()) + ")");
  return lu.solve(f);
}

// The mechanism's joint efforts at (x, xd, xdd) plus the drive layer's joint inertia times
// the joint acceleration: the rigid-body model the indices read (friction left out).
V4 rigid_efforts(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* xdd) {
  V4 tau, qdd;
  d->robot->inverse_dynamics(*m->compiled, *d->rd, x, xd, xdd, tau.data());
  d->robot->joint_acceleration(*m->compiled, *d->rd, x, xd, xdd, qdd.data());
  for (int i = 0; i < kArms; ++i) tau[i] += m->drive->inertia[i] * qdd[i];
  return tau;
}

// Platform-side point mass at E + R e (R = Rz(rz0 + rz)): N += mass D^T D, D = [I | ez x R e].
void add_point(M4& N, double mass, const V3& Re) {
  const V3 v = V3::UnitZ().cross(Re);
  N.topLeftCorner<3, 3>().diagonal().array() += mass;
  N.block<3, 1>(0, 3) += mass * v;
  N.block<1, 3>(3, 0) += mass * v.transpose();
  N(3, 3) += mass * v.squaredNorm();
}

M4 gimre_at(const described::Model& dm, const M4& J, const double* x, const double* q) {
  M4 N = M4::Zero();
  const double th = dm.rz0 + x[3];
  const Eigen::Matrix3d R = Eigen::AngleAxisd(th, V3::UnitZ()).toRotationMatrix();
  for (int i = 0; i < kArms; ++i) {
    const described::LegModel& l = dm.legs[(size_t)i];
    // Link 1 about its axis as the source writes it (ch. 4.4.2): m lg^2 + m (b_r^2 / 3 - b_r lg + lg^2).
    const double br = link_length(l), lg = l.rc, mb = l.m_body;
    const double I1 = mb * lg * lg + mb * (br * br / 3 - br * lg + lg * lg);
    N += I1 * J.row(i).transpose() * J.row(i);
    // The forearm (the rod pair, mass m_rod) as one uniform rod between the elbow B and the
    // platform joint C: T = (m_rod / 6) (|vB|^2 + vB.vC + |vC|^2), its spin neglected.
    const V3 t = l.r * (-std::sin(q[i]) * l.u + std::cos(q[i]) * l.w);  // dB/dq
    Eigen::Matrix<double, 3, 4> Bm = t * J.row(i), Cm;
    Cm.leftCols<3>().setIdentity();
    Cm.col(3) = V3::UnitZ().cross(R * l.p);
    N += (l.m_rod / 3) * (Bm.transpose() * Bm + Cm.transpose() * Cm) +
         (l.m_rod / 6) * (Bm.transpose() * Cm + Cm.transpose() * Bm);
  }
  for (const V3& e : dm.end_bars) add_point(N, 0.5 * dm.m_platform, R * e);
  add_point(N, dm.m_payload, R * dm.c_payload);
  N(3, 3) += dm.I_platform.z();
  return N;
}

const described::Model& checked_model(const pkm_model* m, pkm_data* d) {
  const described::Model& dm = model_of(m, d);
  if (!is_described_quattro(*m->robot))
    throw Error(PKM_ERR_INTERNAL, "quattro facts asked of '" + m->robot_name + "', not a Quattro");
  return dm;
}

}  // namespace

bool is_described_quattro(const Robot& r) {
  const described::DescribedRobot* dr = as_described(r);
  if (!dr) return false;
  const described::Description& desc = dr->description();
  if (desc.structure != described::Structure::legs || !desc.articulated || !desc.dependent.empty() ||
      desc.coords != std::vector<int>{0, 1, 2, 5} || desc.legs.size() != kArms)
    return false;
  // Every leg a revolute arm and a rod to its platform joint (its kind's traits).
  for (const described::LegType* t : desc.legs) {
    const described::LegMotion& k = t->leg->motion();
    if (!k.angular() || !k.has_rod()) return false;
  }
  return true;
}

void index_inputs(const pkm_model* m, pkm_data* d, const double* x, IndexInputs& in) {
  const described::Model& dm = checked_model(m, d);
  double q[kArms];
  d->robot->ik(*m->compiled, *d->rd, x, q);
  const M4 J = jacobian(m, d, x);
  for (int i = 0; i < kArms; ++i) in.JD.row(i) = link_length(dm.legs[(size_t)i]) * J.row(i);
  in.N = gimre_at(dm, J, x, q);
  RowM4 M;
  total_mass_matrix(m, d, x, M.data());
  in.M = M;
  const double zero[4] = {0, 0, 0, 0}, s2 = std::sqrt(0.5);
  const V4 tg = rigid_efforts(m, d, x, zero, zero);
  in.grav = J.transpose() * tg;
  const V4 vz(0, 0, 1, 0), vxy(s2, s2, 0, 0);
  in.hv_z = J.transpose() * (rigid_efforts(m, d, x, vz.data(), zero) - tg);
  in.hv_xy = J.transpose() * (rigid_efforts(m, d, x, vxy.data(), zero) - tg);
  in.tau_z = solve_jt(J, in.M * vz, "alfa index");
  in.tau_x = solve_jt(J, in.M * V4(-s2, -s2, 0, 0), "alfa index");
  in.tau_max = kArmTorqueNominal;
}

Eigen::Matrix4d gimre(const pkm_model* m, pkm_data* d, const double* x) {
  const described::Model& dm = checked_model(m, d);
  double q[kArms];
  d->robot->ik(*m->compiled, *d->rd, x, q);
  return gimre_at(dm, jacobian(m, d, x), x, q);
}

void points(const pkm_model* m, pkm_data* d, const double* x, double* A, double* B, double* C) {
  checked_model(m, d);
  double q[kArms], pts[kArms * 9];
  d->robot->ik(*m->compiled, *d->rd, x, q);  // reach and strokes, as the indices
  d->robot->chain_points(*m->compiled, *d->rd, x, pts);
  for (int i = 0; i < kArms; ++i)
    for (int j = 0; j < 3; ++j) {
      if (A) A[3 * i + j] = pts[9 * i + j];
      if (B) B[3 * i + j] = pts[9 * i + 3 + j];
      if (C) C[3 * i + j] = pts[9 * i + 6 + j];
    }
}

void constants(const pkm_model* m, pkm_data* d, double* out) {
  const described::LegModel& arm1 = checked_model(m, d).legs[0];
  out[0] = kArmTorqueNominal;
  out[1] = kGearRatio;
  out[2] = -arm1.base.z();  // the world origin lies base_height above arm 1's motor axis
  out[3] = link_length(arm1);
}

}  // namespace quattro_facts
}  // namespace pkm
