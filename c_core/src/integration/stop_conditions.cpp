#include "integration/stop_conditions.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "common/guard.hpp"

namespace pkm {

namespace {
// How far (in joint units, or in the singularity measure) a state given to reset may lie
// beyond a stop boundary: a state saved at a stop is there by round-off.
constexpr double kResetSlack = 1e-12;
}  // namespace

// The limits are the robot's own (Robot::joint_limit_param, the same the FMUs and the
// Python package read through pkm_model_joint_limits); a limit set to a huge value means
// "no limit".
void StopConditions::find(pkm_model* copy, double sing_min) {
  sing_min_ = sing_min;
  nd_ = copy->robot->ndof();
  for (int j = 0; j < nd_; ++j) {
    int idx[2] = {-1, -1};
    pkm_model_joint_limits(copy, j, &idx[0], &idx[1]);
    for (int upper = 0; upper < 2; ++upper) {
      if (idx[upper] < 0) continue;
      const double v = pkm_param_get(copy, idx[upper]);
      if (std::isfinite(v) && std::fabs(v) < 1e100)
        limits_.push_back({j, upper != 0, v, pkm_param_name(copy, idx[upper]), pkm_param_unit(copy, idx[upper]),
                           copy->robot->limb_noun()});
    }
  }
  open(copy);
}

// The sim enforces the limits itself, as stop conditions that locate the crossing time.
// A robot's inverse kinematics may refuse strokes outside [qmin, qmax] (the 6-PUS does);
// the stop value must see the stroke just past the limit to find the crossing, and a
// trial step may go there too.  So the sim's private model copy gets each limit
// parameter opened to the end of its valid range; the limits found above stay the stops.
void StopConditions::open(pkm_model* copy) {
  if (limits_.empty()) return;
  std::vector<double> saved = copy->values;
  for (const JointLimit& L : limits_) {
    const int idx = pkm_param_index(copy, L.param.c_str());
    const ParamSpec& spec = copy->specs[idx];
    const double wide = L.upper ? std::min(spec.hi, 1e6) : std::max(spec.lo, -1e6);
    copy->values[idx] = wide;
  }
  char err[512];
  if (pkm_model_validate(copy, err, sizeof err) != PKM_OK) {
    // The robot does not accept open limits: keep them; a crossing may then be reported
    // as the robot's own joint-limit error from inside the step instead of a stop.
    copy->values = saved;
    if (pkm_model_validate(copy, err, sizeof err) != PKM_OK)
      throw Error(PKM_ERR_PARAMETER, std::string("the model copy does not validate: ") + err);
  }
}

void StopConditions::bind(const Robot& robot, const RobotModel& rm, RobotData& rd, const double* y) {
  robot_ = &robot;
  rm_ = &rm;
  rd_ = &rd;
  q_.assign(nd_, 0.0);
  if (sing_min_ > 0) {
    double meas[2];
    try {
      robot.singularity(rm, rd, y, meas);
      sing_root_ = true;
    } catch (const Error& e) {
      if (e.status != PKM_ERR_UNSUPPORTED) throw;
    }
  }
  // The stroke margins, the singularity measure above sing_min, and the sign of det J,
  // which flips when the motion passes through a direct singularity (a dip of the measure
  // below sing_min and back within one step shows no sign change of the measure itself).
  nstop_ = (int)limits_.size() + (sing_root_ ? 1 : 0);
  nroots_ = nstop_ + (sing_root_ ? 1 : 0);
  g_.assign(nroots_, 0.0);
}

double StopConditions::sing_guard() const { return std::min(0.5, kSingGuard * sing_min_); }

int StopConditions::status(int k) const { return is_limit(k) ? PKM_ERR_JOINT_LIMIT : PKM_ERR_SINGULAR; }

void StopConditions::roots(const double* y, double* g, bool exact) {
  int k = 0;
  if (!limits_.empty()) {
    robot_->ik(*rm_, *rd_, y, q_.data());
    for (const JointLimit& L : limits_) g[k++] = L.upper ? L.value - q_[L.joint] : q_[L.joint] - L.value;
  }
  if (sing_root_) {
    if (exact) {
      double meas[2];
      robot_->singularity(*rm_, *rd_, y, meas);
      g[k++] = meas[1] - sing_min_;
    } else {
      g[k++] = 1.0;  // far from the threshold for this segment
    }
    g[k++] = det_j(y);
  }
}

void StopConditions::guard(const double* y, double* g, double& det, double& bound) {
  int k = 0;
  if (!limits_.empty()) {
    robot_->ik(*rm_, *rd_, y, q_.data());
    for (const JointLimit& L : limits_) g[k++] = L.upper ? L.value - q_[L.joint] : q_[L.joint] - L.value;
  }
  det = 1.0;
  bound = 1.0;
  if (sing_root_) {
    robot_->direct_singularity_guard(*rm_, *rd_, y, &bound, &det);
    g[k++] = bound >= sing_guard() ? bound - sing_min_ : measure(y) - sing_min_;
  }
}

double StopConditions::measure(const double* y) {
  double meas[2];
  robot_->singularity(*rm_, *rd_, y, meas);
  return meas[1];
}

double StopConditions::det_j(const double* y) {
  using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, 6, 6>;
  Mat J(nd_, nd_);
  robot_->jacobians(*rm_, *rd_, y, nullptr, nullptr, J.data());
  return Eigen::PartialPivLU<Mat>(J).determinant();
}

std::string StopConditions::message(int k, const double* g, double t, bool at_start) const {
  std::ostringstream os;
  os.precision(10);
  if (is_limit(k)) {
    const JointLimit& L = limits_[k];
    const double q = L.upper ? L.value - g[k] : L.value + g[k];
    const char* kind = robot_->joints_angular() ? "joint limit" : "stroke limit";
    os << L.noun << " " << (L.joint + 1) << (at_start ? " is at or beyond its " : " reached its ") << kind << " "
       << L.param << " = " << L.value << " " << L.unit << " at t = " << t << " s (q" << (L.joint + 1) << " = " << q
       << " " << L.unit << ")";
  } else {
    const double meas = g[k] + sing_min_;
    if (at_start)
      os << "direct (type 2) singularity: measure " << std::setprecision(4) << meas << " <= sing_min = " << sing_min_
         << std::setprecision(10) << " at t = " << t << " s";
    else
      os << "direct (type 2) singularity: measure " << std::scientific << std::setprecision(6) << meas
         << std::defaultfloat << std::setprecision(10) << " reached sing_min = " << sing_min_ << " at t = " << t << " s";
  }
  if (at_start) os << "; the simulation cannot go on from this state: reset it to one inside the limits";
  return os.str();
}

void StopConditions::check_start(const double* y) {
  try {
    roots(y, g_.data());
  } catch (const Error& e) {
    throw Error(e.status, std::string("reset: ") + e.what());
  }
  for (int k = 0; k < nstop_; ++k) {
    if (g_[k] < -kResetSlack) {
      std::ostringstream os;
      os.precision(10);
      if (is_limit(k)) {
        const JointLimit& L = limits_[k];
        os << "reset: " << L.noun << " " << (L.joint + 1) << " stroke q" << (L.joint + 1) << " = "
           << (L.upper ? L.value - g_[k] : L.value + g_[k]) << " " << L.unit << " is beyond its limit " << L.param
           << " = " << L.value << " " << L.unit;
      } else {
        os << "reset: the pose is too close to a direct (type 2) singularity (measure " << std::setprecision(3)
           << g_[k] + sing_min_ << " < sing_min = " << sing_min_ << ")";
      }
      throw Error(status(k), os.str());
    }
  }
}

}  // namespace pkm
