#include "integration/step_budget.hpp"

#include <cmath>
#include <sstream>

#include "common/guard.hpp"

namespace pkm {

namespace {
// With a time limit, the clock is read every this many steps or right-hand sides.
constexpr long kClockEvery = 32;
}  // namespace

void StepBudget::set_time_limit(double seconds) {
  PKM_REQUIRE(std::isfinite(seconds) && seconds >= 0, PKM_ERR_ARGUMENT,
              "time limit = " + num(seconds) + " s must be finite and >= 0 (0 = none)");
  time_limit_ = seconds;
}

void StepBudget::start(double t0, double t_end) {
  left_ = max_steps_;
  t0_ = t0;
  end_ = t_end;
  if (time_limit_ > 0)
    deadline_ = std::chrono::steady_clock::now() +
                std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(time_limit_));
}

bool StepBudget::past_deadline() {
  // The clock is read every kClockEvery calls (~50 ns a read, a step costs microseconds).
  if (!(time_limit_ > 0) || ++clock_calls_ % kClockEvery != 0) return false;
  return std::chrono::steady_clock::now() > deadline_;
}

std::string StepBudget::message(double t_now, double t_end, bool clock) const {
  std::ostringstream os;
  os.precision(10);
  os << "step budget exceeded at t = " << t_now << " s: ";
  if (clock)
    os << "in its time limit of " << time_limit_ << " s (wall clock) the advance from t = " << t0_ << " s went only ";
  else
    os << "max_steps = " << max_steps_ << " internal steps took the advance from t = " << t0_ << " s only ";
  os << (t_now - t0_) << " s of the " << (t_end - t0_) << " s to t = " << t_end << " s; " << advice_;
  return os.str();
}

void StepBudget::exceeded(double t_now, double t_end, bool clock) const {
  throw Error(PKM_ERR_STEP_BUDGET, message(t_now, t_end, clock));
}

}  // namespace pkm
