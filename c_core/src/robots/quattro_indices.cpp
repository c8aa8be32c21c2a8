// C API specific to the Quattro: the kinematic and dynamic performance indices of Virzi 2010
// ch. 3-5 over a batch of poses (the workspace maps), the GIMRE and the joint points of a
// described Quattro (quattro_facts.hpp), or of a model giving them itself (OwnFacts: the test
// oracle): the index formulas once, over the inputs each model gives.
#include <cstring>

#include "common/guard.hpp"
#include "robots/quattro_facts.hpp"

using namespace pkm;

namespace {

struct IndexInfo {
  const char* name;
  const char* unit;
};

constexpr IndexInfo kIndex[PKM_QUATTRO_NINDEX] = {
    {"mu_T", "1"},    {"mu_xy", "1"},    {"mu_z", "1"},  {"mu_T_eig", "1"}, {"mu_xy_eig", "1"}, {"mu_z_eig", "1"},
    {"kappa_T", "1"}, {"dTIM", "1"},     {"dTIM_xy", "kg2"}, {"dTIM_x", "kg"}, {"dTIM_y", "kg"}, {"dTIM_z", "kg"},
    {"kat", "kg"},    {"kat_xy", "kg"},  {"kat_x", "kg"}, {"kat_y", "kg"},    {"kat_z", "kg"},     {"Fcc_z", "N"},
    {"Fcc_xy", "N"},  {"Fgr", "N"},      {"alfa_z", "m/s2"}, {"alfa_x", "m/s2"}};

constexpr IndexInfo kConstant[PKM_QUATTRO_NCONSTANT] = {
    {"tau_arm_max", "N.m"}, {"gear_ratio", "1"}, {"base_height", "m"}, {"link_length", "m"}};

// The model's own facts (the test oracle), or nullptr for a described Quattro; throws for any
// other robot.
const quattro_facts::OwnFacts* quattro_model(const pkm_model* m, pkm_data* d) {
  const RobotModel& rm = prepare(m, d);
  if (quattro_facts::is_described_quattro(*m->robot)) return nullptr;
  if (const auto* own = dynamic_cast<const quattro_facts::OwnFacts*>(&rm)) return own;
  throw Error(PKM_ERR_ARGUMENT, "this function is for a Quattro ('quattro', or a description of four arms on an articulated platform), not '" +
                                    m->robot_name + "'");
}

// Largest scale s of a unit task acceleration a such that |J^-T M a| <= tau_max on every
// arm: the source's alfa (ch. 5.6-5.7), from rest and without gravity; tau = J^-T M a.
double alfa(double tau_max, const Eigen::Vector4d& tau) {
  const double t = tau.cwiseAbs().maxCoeff();
  if (!(t > 0)) throw Error(PKM_ERR_SINGULAR, "alfa index: zero torque for a unit acceleration");
  return tau_max / t;
}

}  // namespace

namespace pkm {
namespace quattro_facts {

void indices(const IndexInputs& in, double* out) {
  const Eigen::Matrix4d& JD = in.JD;
  double* o = out;
  // Kinematic indices (ch. 3): sub-matrix variants on columns of the normalised J.
  const Eigen::Matrix<double, 4, 3> JT = JD.leftCols<3>();
  const Eigen::Matrix<double, 4, 2> Jxy = JD.leftCols<2>();
  o[0] = 1 / std::sqrt((JT.transpose() * JT).determinant());
  o[1] = 1 / std::sqrt((Jxy.transpose() * Jxy).determinant());
  o[2] = 1 / JD.col(2).norm();
  // Eigenvalue variants: the source reads the smallest eigenvalue of JD^T JD as the rotation,
  // the largest as z and the two middle ones as the horizontal directions.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> es(JD.transpose() * JD, Eigen::EigenvaluesOnly);
  const Eigen::Vector4d l = es.eigenvalues();
  o[3] = 1 / std::sqrt(l[1] * l[2] * l[3]);
  o[4] = 1 / std::sqrt(l[1] * l[2]);
  o[5] = 1 / std::sqrt(l[3]);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es3(JT.transpose() * JT, Eigen::EigenvaluesOnly);
  o[6] = std::sqrt(es3.eigenvalues()[2] / es3.eigenvalues()[0]);
  // GIMRE (ch. 4).
  const Eigen::Matrix4d& Nm = in.N;
  const Eigen::Matrix3d TIM = Nm.topLeftCorner<3, 3>();
  const double tr = TIM.trace();
  o[7] = 27 * TIM.determinant() / (tr * tr * tr);
  const Eigen::Matrix<double, 2, 4> N2 = Nm.topRows<2>();
  o[8] = std::sqrt((N2 * N2.transpose()).determinant());
  o[9] = Nm.row(0).norm();
  o[10] = Nm.row(1).norm();
  o[11] = Nm.row(2).norm();
  // Dynamic model (ch. 5): mass indices from L = M[0:3,0:3].
  const Eigen::Matrix4d& M = in.M;
  const double kx = M.block<1, 3>(0, 0).norm(), ky = M.block<1, 3>(1, 0).norm(), kz = M.block<1, 3>(2, 0).norm();
  o[12] = (kx + ky + kz) / 3;
  o[13] = (kx + ky) / 2;
  o[14] = kx;
  o[15] = ky;
  o[16] = kz;
  o[17] = in.hv_z.head<3>().norm();
  o[18] = in.hv_xy.head<3>().norm();
  o[19] = in.grav.head<3>().norm();
  o[20] = alfa(in.tau_max, in.tau_z);
  o[21] = alfa(in.tau_max, in.tau_x);
  for (int k = 0; k < PKM_QUATTRO_NINDEX; ++k)
    if (!std::isfinite(o[k]))
      throw Error(PKM_ERR_SINGULAR, std::string("index ") + kIndex[k].name + " is not finite at this pose");
}

}  // namespace quattro_facts
}  // namespace pkm

extern "C" {

const char* pkm_quattro_index_name(int i) { return i >= 0 && i < PKM_QUATTRO_NINDEX ? kIndex[i].name : ""; }
const char* pkm_quattro_index_unit(int i) { return i >= 0 && i < PKM_QUATTRO_NINDEX ? kIndex[i].unit : ""; }

int pkm_quattro_indices(const pkm_model* m, pkm_data* d, size_t n, const double* x, double* out, int* status) {
  const quattro_facts::OwnFacts* qm = nullptr;
  int s = guard(d, [&] {
    qm = quattro_model(m, d);
    check_out(x, "x");
    check_out(out, "out");
  });
  if (s != PKM_OK) return s;
  return run_batch(d, n, status, out, PKM_QUATTRO_NINDEX, [&](size_t k) {
    check_finite(x + 4 * k, 4, "pose x");
    quattro_facts::IndexInputs in;
    if (qm)
      qm->index_inputs(x + 4 * k, in);
    else
      quattro_facts::index_inputs(m, d, x + 4 * k, in);
    quattro_facts::indices(in, out + PKM_QUATTRO_NINDEX * k);
  });
}

const char* pkm_quattro_constant_name(int i) { return i >= 0 && i < PKM_QUATTRO_NCONSTANT ? kConstant[i].name : ""; }
const char* pkm_quattro_constant_unit(int i) { return i >= 0 && i < PKM_QUATTRO_NCONSTANT ? kConstant[i].unit : ""; }

int pkm_quattro_constants(const pkm_model* m, pkm_data* d, double* out) {
  return guard(d, [&] {
    const quattro_facts::OwnFacts* qm = quattro_model(m, d);
    check_out(out, "out");
    if (qm) return qm->constants(out);
    quattro_facts::constants(m, d, out);
  });
}

int pkm_quattro_gimre(const pkm_model* m, pkm_data* d, const double* x, double* Nout) {
  return guard(d, [&] {
    const quattro_facts::OwnFacts* qm = quattro_model(m, d);
    check_finite(x, 4, "pose x");
    check_out(Nout, "N");
    Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>> out(Nout);
    out = qm ? qm->gimre(x) : quattro_facts::gimre(m, d, x);
  });
}

int pkm_quattro_points(const pkm_model* m, pkm_data* d, const double* x, double* A, double* B, double* C) {
  return guard(d, [&] {
    const quattro_facts::OwnFacts* qm = quattro_model(m, d);
    check_finite(x, 4, "pose x");
    if (qm)
      qm->points(x, A, B, C);
    else
      quattro_facts::points(m, d, x, A, B, C);
  });
}

}  // extern "C"
