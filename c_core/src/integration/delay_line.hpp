// The two delay lines of a sim: the actuator's (drive parameter actuator.delay, the
// mechanism feels the command issued that much earlier) and the closed loop's readings
// (sensor.delay, the controller reads the joints of that much earlier).  Both are
// rolled back with the sim: a reset to t0 forgets what was recorded at or after t0.
#pragma once

#include <cstddef>
#include <vector>

namespace pkm {

// The commands held over past advances, each from its start time s.  Kept for kHistory
// seconds beyond the delay so that a rollback within it replays exactly.
class CommandDelay {
 public:
  CommandDelay() = default;
  CommandDelay(int nd, double delay) : nd_(nd), delay_(delay) {}
  bool active() const { return delay_ > 0; }
  double delay() const { return delay_; }
  // A command held from time s on: replaces any recorded at or after s (a rollback's).
  void issue(double s, const double* tau);
  // The first time in (t, t_end) where a recorded command starts to act (t_end if none):
  // the applied effort is constant between two such switches.
  double next_switch(double t, double t_end) const;
  // The command issued at time t (zero before the first one).
  void command_at(double t, double* tau) const;
  // The command acting on the mechanism at time t: the one issued at t - delay.
  void acting_at(double t, double* tau) const;
  // Forgets the commands no rollback within kHistory seconds of t can need.
  void forget_before(double t);
  // Forgets the commands issued at or after t0 (they belong to a future rolled back).
  void rollback(double t0);

  // Saved state: the commands that can still act at or after t (the last one issued
  // before t - delay and every later one), as a count then (s, tau[nd]) per command.
  size_t saved_count(double t) const;
  void save(double t, double* b) const;  // writes 1 + saved_count(t) (1 + nd) values
  // Checks a saved line of nh commands (issue times in order, none after t); throws.
  static void check_saved(const double* b, size_t nh, int nd, double t);
  void load(const double* b, size_t nh);

 private:
  struct Command {
    double s;
    double tau[6];
  };
  size_t first_saved(double t) const;
  int nd_ = 0;
  double delay_ = 0.0;
  std::vector<Command> history_;
};

// The closed loop's delay line of joint readings: the reading and rate of past samples.
class ReadingDelay {
 public:
  ReadingDelay() = default;
  ReadingDelay(int nd, double delay) : nd_(nd), delay_(delay) {}
  // Records the sample (t, q, qd) and replaces q, qd by the reading and rate at t - delay,
  // interpolated linearly between the samples around it (the first sample's before it).
  // Without a delay it does nothing.
  void read(double t, double* q, double* qd);
  void rollback(double t0);

 private:
  struct Reading {
    double t;
    double q[6], qd[6];
  };
  int nd_ = 0;
  double delay_ = 0.0;
  std::vector<Reading> readings_;
};

}  // namespace pkm
