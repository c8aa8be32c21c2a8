#include "integration/delay_line.hpp"

#include <cmath>

#include "common/guard.hpp"

namespace pkm {

namespace {
// How far back (simulated seconds) the actuator delay line is kept for rollbacks.
constexpr double kHistory = 1.0;
}  // namespace

void CommandDelay::issue(double s, const double* tau) {
  rollback(s);
  Command c;
  c.s = s;
  for (int i = 0; i < nd_; ++i) c.tau[i] = tau[i];
  history_.push_back(c);
}

double CommandDelay::next_switch(double t, double t_end) const {
  double b = t_end;
  for (const Command& h : history_) {
    const double sw = h.s + delay_;
    if (sw > t && sw < b) b = sw;
  }
  return b;
}

void CommandDelay::command_at(double t, double* tau) const {
  if (history_.empty() || t < history_.front().s) {
    // Before the first recorded command (the start of the run) nothing was commanded.
    for (int i = 0; i < nd_; ++i) tau[i] = 0.0;
    return;
  }
  size_t k = history_.size() - 1;
  while (k > 0 && history_[k].s > t) --k;
  for (int i = 0; i < nd_; ++i) tau[i] = history_[k].tau[i];
}

void CommandDelay::acting_at(double t, double* tau) const {
  // A command whose delayed start falls on t (a delay of whole periods) acts from t on:
  // the sample time and the history's start times are sums of periods, equal to rounding.
  command_at(t - delay_ + 1e-12, tau);
}

void CommandDelay::forget_before(double t) {
  const double keep_from = t - delay_ - kHistory;
  size_t first = 0;
  while (first + 1 < history_.size() && history_[first + 1].s <= keep_from) ++first;
  if (first > 0) history_.erase(history_.begin(), history_.begin() + (long)first);
}

void CommandDelay::rollback(double t0) {
  while (!history_.empty() && history_.back().s >= t0) history_.pop_back();
}

size_t CommandDelay::first_saved(double t) const {
  for (size_t j = 0; j < history_.size(); ++j)
    if (j + 1 == history_.size() || history_[j + 1].s > t - delay_) return j;
  return history_.size();
}

size_t CommandDelay::saved_count(double t) const { return history_.size() - first_saved(t); }

void CommandDelay::save(double t, double* b) const {
  const size_t first = first_saved(t);
  size_t k = 0;
  b[k++] = (double)(history_.size() - first);
  for (size_t j = first; j < history_.size(); ++j) {
    b[k++] = history_[j].s;
    for (int i = 0; i < nd_; ++i) b[k++] = history_[j].tau[i];
  }
}

void CommandDelay::check_saved(const double* b, size_t nh, int nd, double t) {
  // The delay line: commands in the order they were issued, none after t.
  const size_t row = 1 + (size_t)nd;
  for (size_t j = 0; j < nh; ++j) {
    const double s = b[j * row];
    PKM_REQUIRE(s <= t && (j == 0 || s >= b[(j - 1) * row]), PKM_ERR_ARGUMENT,
                "state: delay-line command " + std::to_string(j) + " issued at t = " + num(s) +
                    " s is out of order or after the state's time " + num(t) + " s");
  }
}

void CommandDelay::load(const double* b, size_t nh) {
  history_.clear();
  size_t k = 0;
  for (size_t j = 0; j < nh; ++j) {
    Command c{};
    c.s = b[k++];
    for (int i = 0; i < nd_; ++i) c.tau[i] = b[k++];
    history_.push_back(c);
  }
}

void ReadingDelay::read(double t, double* q, double* qd) {
  if (!(delay_ > 0)) return;
  Reading r{};
  r.t = t;
  for (int i = 0; i < nd_; ++i) r.q[i] = q[i], r.qd[i] = qd[i];
  readings_.push_back(r);
  const double s = t - delay_;
  // Keep one sample at or before the oldest time a later call can ask for (s grows).
  size_t drop = 0;
  while (drop + 1 < readings_.size() && readings_[drop + 1].t <= s) ++drop;
  if (drop > 0) readings_.erase(readings_.begin(), readings_.begin() + (long)drop);
  const Reading& a = readings_.front();
  if (s <= a.t || readings_.size() == 1) {
    for (int i = 0; i < nd_; ++i) q[i] = a.q[i], qd[i] = a.qd[i];
    return;
  }
  const Reading& b = readings_[1];
  const double f = (s - a.t) / (b.t - a.t);
  for (int i = 0; i < nd_; ++i) {
    q[i] = a.q[i] * (1 - f) + b.q[i] * f;
    qd[i] = a.qd[i] * (1 - f) + b.qd[i] * f;
  }
}

void ReadingDelay::rollback(double t0) {
  while (!readings_.empty() && readings_.back().t >= t0) readings_.pop_back();
}

}  // namespace pkm
