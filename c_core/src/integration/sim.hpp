// CVODE integration of a robot's task-space state (x, xd) under a zero-order-hold
// input tau: the implementation behind pkm_sim (see integration/sim_api.cpp and
// docs/integration.md).
//
// The simulator is written against the Robot interface only, so it serves every robot
// that provides forward_dynamics (directly or through the generic form).  Its stop
// conditions come from the model's named parameters (stroke / joint limits) and from
// the robot's singularity measure, both found at construction.
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sundials/sundials_linearsolver.h>
#include <sundials/sundials_matrix.h>
#include <sundials/sundials_nonlinearsolver.h>

#include "common/handles.hpp"
#include "dynamics/drive.hpp"

namespace pkm {

// One actuated-joint limit found among the model parameters: the root function
// g = q_j - value (lower) or value - q_j (upper) stops the integration at g = 0.
struct JointLimit {
  int joint;          // 0-based actuated joint
  bool upper;         // qmax (true) or qmin (false)
  double value;       // [m or rad]
  std::string param;  // its parameter name, e.g. "rail[3].qmax"
  std::string unit;   // its unit
  std::string noun;   // "leg", "arm" or "joint" (how the message names the joint)
};

class Sim {
 public:
  // Copies the model (later changes of the caller's model do not reach the sim) and
  // validates the options; throws Error naming the bad option.  The initial state is
  // the robot's home pose at rest, t = 0, tau = 0.
  Sim(const pkm_model* m, const pkm_sim_options& opt);
  ~Sim();
  Sim(const Sim&) = delete;
  Sim& operator=(const Sim&) = delete;

  // Throws Error (state unchanged) on a non-finite, unreachable, out-of-limit or singular state.
  void reset(double t0, const double* x, const double* xd);
  void set_input(const double* tau);
  // Integrates to t_end; on a stop or failure, keeps the state where it stopped and
  // throws Error with the status and a message naming the leg and the time.
  void advance(double t_end);
  void get_state(double* t, double* x, double* xd) const;
  // Drive-side position and rate per joint: the drive body's for a two-body joint
  // (drive.two_body), the joint's own otherwise.
  void drive_state(double* theta, double* theta_d);
  bool two_body() const { return !two_.empty(); }
  // Pose acceleration at the current state under the command tau (dead zone, saturation).
  void acceleration(const double* tau, double* xdd);
  const pkm_sim_stats& stats() const { return stats_; }
  // A wall-clock limit per advance [s] (0: none): past it the advance stops as if its step
  // budget ran out.  The one result of a sim that depends on the machine, for hosts that
  // must get an answer in bounded time (the FMUs).
  void set_time_limit(double seconds);
  int ndof() const { return nd_; }
  bool explicit_method() const { return opt_.method == PKM_ERK || opt_.method == PKM_ERK23; }
  // Everything that determines the future of the sim (pkm_sim_state_*): t, state, held
  // input, the explicit method's next step size and the actuator-delay history it needs.
  size_t state_size() const;
  void state_save(double* buf) const;
  void state_load(const double* buf, size_t n);

  std::string error;  // message of the last failure (pkm_sim_error)

  // The sim's own model copy and work data (for the closed loop's joint readings).
  const pkm_model* model() const { return model_; }
  pkm_data* data() const { return data_; }
  const double* held_input() const { return tau_.data(); }
  // The effort acting on the mechanism at the sim's time from the commands issued before
  // it: the held input, or with an actuator delay the command issued at t - delay (zero
  // before the first).  What the sensor model's compliance deflects under at a sample.
  void applied_effort(double* tau) const;
  // A known external effort per joint [N or N m] (a measured force on the carriage), held
  // from now on and added to the actuator effort, with no saturation and no delay.
  void set_external(const double* f);
  bool actuator_delayed() const { return delay_ > 0; }

  // The closed loop's delay line of joint readings (drive parameter sensor.delay > 0): the
  // reading and rate of past samples; reset() drops those at or after its t0 (a rollback),
  // as it does for the actuator delay line.
  struct Reading {
    double t;
    double q[6], qd[6];
  };
  std::vector<Reading> readings;
  // The reading and rate at time t (delayed): recorded at t, interpolated linearly between
  // the samples around t - sensor.delay (the first sample's before it).  Records the sample.
  void delayed_reading(double t, double* q, double* qd);

 private:
  static int rhs_cb(double t, N_Vector y, N_Vector ydot, void* self);
  static int root_cb(double t, N_Vector y, double* g, void* self);
  static void err_cb(int code, const char* module, const char* fn, char* msg, void* self);

  void release();  // frees the CVODE objects and the model copy (idempotent)
  void find_limits();
  void open_limits();
  void stop_inside(double t_start);
  // Fills g[nroots_]; throws Error from the robot (unreachable pose...).
  void roots(const double* y, double* g);
  // The message of root k crossing zero at time t, with the state y there.
  std::string root_message(int k, const double* g, double t, bool at_start) const;
  void check_cvode(int flag, const char* call) const;
  // The command issued at time t, from the delay line (zero before the first one).
  void command_at(double t, double* tau) const;
  // Integrates one segment [t_, b] with a constant applied effort; throws on a stop.
  // segment() decides whether the singularity root is needed, integrate() runs CVODE.
  void segment(double b);
  void integrate(double b);
  // The explicit Runge-Kutta path (integration/erk.cpp): one segment [t_, b] with a
  // constant applied effort, steps carried across advances through h_next_.  false: the
  // motion turned stiff (the step size is held by stability, not accuracy), the state is
  // at the last accepted step before b and BDF takes the rest.
  bool erk_segment(double b);
  // CVODE's objects for PKM_BDF or PKM_ADAMS (at construction, or when a stiff stretch
  // hands an explicit segment to BDF).
  void cvode_create(int lmm);
  // Throws PKM_ERR_STEP_BUDGET: the advance to t_end used its max_steps internal steps
  // (clock false) or ran into its time limit (clock true).
  [[noreturn]] void budget_exceeded(double t_end, bool clock) const;
  std::string budget_message(double t_end, bool clock) const;
  // With a time limit: true once the current advance is past its deadline (reads the
  // clock every few calls).
  bool past_deadline();
  // The state's rates f(y) under the applied effort u: (xd, FD) and, for the two-body
  // joints, (theta_d, theta_dd) with the transmission's effort driving the carriage.
  void dynamics(const double* y, const double* u, double* f);
  // The joints q and rates qd of the robot at state y (throws like the robot's IK).
  void joints_of(const double* y, double* q, double* qd);
  // f = (xd, FD(y, tau)), tau nullptr: zero effort; with B != nullptr also B = d xdd / d tau
  // when the robot offers it (else reuse_input_ turns false).  false: a recoverable
  // failure (cb_*).
  bool erk_rhs(double t, const double* y, double* f, const double* tau, double* B = nullptr);
  // A stage from its split: f = F + (0, B applied_), F = f at zero effort.
  void erk_stage(const double* F, const double* B, double* f) const;
  double erk_initial_step(double t_end, const double* f0);
  // Stop-condition values at y (limits, then the singularity margin) and the det J sign
  // value; the exact singularity measure only where the cheap bound is near sing_min.
  void erk_guard(const double* y, double* g, double& det, double& bound);
  // First violation of a stop condition inside the accepted step [t0, t0 + h] (Hermite
  // interpolant of y0, f0, y1, f1): stops there and throws.
  [[noreturn]] void erk_stop(double t0, double h, const double* y0, const double* f0, const double* y1,
                             const double* f1, double det0);
  double measure_at(const double* y);  // direct-singularity measure (robot's measures[1])
  double det_j(const double* y);       // det J = det(Jq^-1 Jx): changes sign through a direct singularity
  void stop_before_singularity(double t_start);

  pkm_model* model_ = nullptr;  // owned copy
  pkm_data* data_ = nullptr;    // owned work data
  const Robot* robot_ = nullptr;
  const RobotModel* rm_ = nullptr;
  RobotData* rd_ = nullptr;
  int nd_ = 0;
  int ny_ = 0;            // state length: 2 nd, or 4 nd with two-body joints (y = [x, xd, theta, theta_d])
  std::vector<int> two_;  // the two-body joints (drive.two_body)
  std::shared_ptr<const drive::Params> carriage_;  // the drive layer less the two-body joints' drive bodies
  pkm_sim_options opt_{};

  std::vector<JointLimit> limits_;
  bool sing_root_ = false;  // the robot provides singularity measures and sing_min > 0
  bool sing_exact_ = true;  // the singularity root is evaluated (else reported far away)
  std::vector<double> y_save_;  // segment start, for a re-run with the singularity root on
  int nstop_ = 0;   // roots that are stop conditions: limits, then the singularity measure
  int nroots_ = 0;  // nstop_ plus the det J sign root

  double t_ = 0.0;
  std::vector<double> y_;    // state [x, xd] (2 nd), then [theta, theta_d] of the drive bodies (2 nd) if any
  std::vector<double> tau_;      // held command (after saturation), nd
  std::vector<double> applied_;  // effort reaching the mechanism in the current segment, nd
  std::vector<double> external_;  // known external effort held (set_external), nd
  void add_external() {
    for (int i = 0; i < nd_; ++i) applied_[i] += external_[i];
  }

  // Actuator delay line (drive parameter actuator.delay > 0): the command held over each
  // past advance, from its start time s_k; the mechanism feels the command issued at
  // t - delay.  Kept for kHistory seconds so that rollbacks within it replay exactly.
  struct Command {
    double s;
    double tau[6];
  };
  std::vector<Command> history_;
  double delay_ = 0.0;
  std::vector<double> q_;    // work buffer for the root function
  std::vector<double> g_;    // work buffer for root values

  // Failure recorded inside a CVODE callback (no exception may cross CVODE's C frames).
  int cb_status_ = 0;
  double cb_time_ = 0.0;
  std::string cb_msg_;
  std::string cv_msg_;  // last message of CVODE's error handler

  pkm_sim_stats stats_{};
  // Bounded work: internal steps left in the current advance (max_steps at its start; ERK
  // attempts and CVODE steps both count), and where the advance started.
  long budget_ = 0;
  double budget_t0_ = 0.0, budget_end_ = 0.0;
  double time_limit_ = 0.0;  // wall-clock seconds per advance, 0: none (set_time_limit)
  std::chrono::steady_clock::time_point deadline_{};
  long clock_calls_ = 0;
  int cvode_lmm_ = PKM_BDF;   // the method the CVODE objects were made for
  double h_next_ = 0.0;  // explicit method: step size proposed for the next step (0: choose one)
  // Explicit method: stop-condition values and det J at the state it ended on (valid
  // until the state changes otherwise), so the next advance need not recompute them.
  bool guard_cached_ = false;
  double det_cached_ = 1.0, bound_cached_ = 1.0;
  std::vector<double> g_cached_;
  // Explicit method: the last stage of a segment split as f(y_, 0) (fsal_f_) and B = d xdd
  // / d tau (fsal_B_).  The accelerations are affine in the effort, so the first stage of
  // the next segment is fsal_f_ + B applied_ whatever its input: a 6x6 product instead of
  // a forward-dynamics call.  The split depends on y_ alone, so after a reset or a load it
  // is recomputed to the same bits: a rollback (and a reset to a saved state) repeats
  // the trajectory bit for bit.
  bool reuse_input_ = false;  // the robot offers B and the drive has no rotor inertia
  bool fsal_valid_ = false;   // fsal_f_ and fsal_B_ belong to the current y_
  std::vector<double> fsal_f_, fsal_B_;

  SUNContext ctx_ = nullptr;
  N_Vector nv_ = nullptr;
  N_Vector nv_back_ = nullptr;  // state interpolated just before a root
  SUNMatrix A_ = nullptr;
  SUNLinearSolver ls_ = nullptr;
  SUNNonlinearSolver nls_ = nullptr;
  void* cvode_ = nullptr;
};

}  // namespace pkm

struct pkm_sim {
  pkm::Sim sim;
  pkm_sim(const pkm_model* m, const pkm_sim_options& o) : sim(m, o) {}
};
