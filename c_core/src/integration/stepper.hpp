// An integrator of a sim, as a stepper: it advances the sim's state over one segment
// under a constant applied effort, checking the stop conditions on the way, and keeps
// what it carries from one segment to the next (a step size, a cached stage).
//
// A sim runs one stepper, chosen by pkm_sim_options.method in the table of
// integration/stepper.cpp (make_stepper).  Adding an integrator is one file holding its
// Stepper class and its factory, plus its line in that table and its method constant in
// pkm.h.  The steppers of today: integration/erk_stepper.cpp (explicit Runge-Kutta pairs)
// and integration/cvode_stepper.cpp (SUNDIALS CVODE, BDF and Adams; left out of builds
// without SUNDIALS, PKM_NO_CVODE).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "pkm/pkm.h"

namespace pkm {

class Ode;
class StopConditions;
class StepBudget;

// The initial-value problem the steppers of a sim advance: the sim's state (t, y), the
// effort applied over the current segment, and what the state equation, the stop
// conditions and the work bound are.  Owned by the sim; a stepper keeps a reference.
struct Ivp {
  const pkm_sim_options& opt;
  Ode& ode;
  StopConditions& stops;
  StepBudget& budget;
  pkm_sim_stats& stats;
  double& t;
  std::vector<double>& y;              // the committed state, ny values
  const std::vector<double>& applied;  // effort reaching the mechanism in the segment, nd
};

class Stepper {
 public:
  explicit Stepper(Ivp& ivp)
      : opt_(ivp.opt),
        ode_(ivp.ode),
        stops_(ivp.stops),
        budget_(ivp.budget),
        stats_(ivp.stats),
        t_(ivp.t),
        y_(ivp.y),
        applied_(ivp.applied) {}
  virtual ~Stepper() = default;
  Stepper(const Stepper&) = delete;
  Stepper& operator=(const Stepper&) = delete;
  // The state changed otherwise than by this stepper (a reset, a load, another stepper):
  // forget what was carried from the last segment.
  virtual void restart() = 0;
  // The stop values g[nstop] at the current state, checked before an advance (a state on
  // or beyond a stop cannot be advanced).  Throws Error from the robot.
  virtual void start_values(double* g) = 0;
  // Integrates from ivp.t to t_end with ivp.applied held; on a stop or a failure keeps
  // the state where it stopped and throws Error naming the time.  false: the motion
  // turned stiff, the state is at the last accepted step before t_end, and the sim hands
  // the rest to a stiff stepper (only when one is there to take it).
  virtual bool advance(double t_end) = 0;
  // What it carries between advances, as a fixed block of the sim's saved state.
  virtual size_t state_size() const = 0;
  virtual void save(double* b) const = 0;
  // Throws (nothing changed) if b is no block this stepper can take at time t.
  virtual void check(const double* b, double t) const = 0;
  virtual void load(const double* b) = 0;
  // What the message of an exceeded step budget advises with this stepper.
  virtual std::string budget_advice() const = 0;

 protected:
  // The parts of the Ivp, by name.
  const pkm_sim_options& opt_;
  Ode& ode_;
  StopConditions& stops_;
  StepBudget& budget_;
  pkm_sim_stats& stats_;
  double& t_;
  std::vector<double>& y_;
  const std::vector<double>& applied_;
};

// The stepper of method (a pkm_lmm).  stiff_fallback: a stiff stepper exists for an
// explicit one to hand a stiff stretch to.  Throws if the method is unknown or not in
// this build.
std::unique_ptr<Stepper> make_stepper(int method, Ivp& ivp);
// Whether this build has method.
bool stepper_available(int method);
// Throws Error (PKM_ERR_ARGUMENT) naming the methods if method is none of them, or
// saying why this build does not have it.
void check_method(int method);

// Checks a saved next step size at time t: 0 (choose one) or a step that can be taken.
void check_next_step(double h, double t);

// The factories of the steppers (one per file).
std::unique_ptr<Stepper> make_erk_stepper(int method, Ivp& ivp, bool stiff_fallback);
std::unique_ptr<Stepper> make_cvode_stepper(int method, Ivp& ivp);

}  // namespace pkm
