// The bounded work of one advance: at most max_steps internal steps (every stepper that
// runs in the advance draws on the same count: a stiff hand-over goes on with what is
// left) and, for hosts that must answer in bounded time, a wall-clock limit.
#pragma once

#include <chrono>
#include <string>

namespace pkm {

class StepBudget {
 public:
  StepBudget() = default;
  // advice: what the message of an exceeded budget tells the user to change (it depends
  // on the sim's integrator: Stepper::budget_advice).
  StepBudget(long max_steps, std::string advice) : max_steps_(max_steps), advice_(std::move(advice)) {}
  // A wall-clock limit per advance [s] (0: none); throws Error on a bad value.
  void set_time_limit(double seconds);
  // An advance from t0 to t_end starts: max_steps steps and a new deadline.
  void start(double t0, double t_end);
  long left() const { return left_; }
  void spend(long steps) { left_ -= steps; }
  double t_end() const { return end_; }
  // With a time limit: true once the current advance is past its deadline (reads the
  // clock every few calls).
  bool past_deadline();
  // Throws PKM_ERR_STEP_BUDGET, the state being at t_now in a segment to t_end: the steps
  // ran out (clock false) or the time limit did (clock true).
  [[noreturn]] void exceeded(double t_now, double t_end, bool clock) const;
  std::string message(double t_now, double t_end, bool clock) const;

 private:
  long max_steps_ = 0;
  std::string advice_;
  long left_ = 0;
  double t0_ = 0.0, end_ = 0.0;
  double time_limit_ = 0.0;  // wall-clock seconds per advance, 0: none
  std::chrono::steady_clock::time_point deadline_{};
  long clock_calls_ = 0;
};

}  // namespace pkm
