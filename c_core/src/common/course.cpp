// C API: time courses of named parameters (pkm_param_set_course and its readers).  The sim
// evaluates them (integration/ode.cpp, Ode::trends_at and Ode::steps_at).
#include "common/course.hpp"

#include <cmath>

#include "common/guard.hpp"

namespace pkm {

void check_course_value(const ParamSpec& s, const Course& c, double v, double t) {
  if (std::isfinite(v) && v >= s.lo && v <= s.hi) return;
  const std::string how = c.kind == PKM_COURSE_TREND
                              ? "its trend of " + num(c.change, 6) + " " + s.unit + "/s from t0 = " + num(c.t0) + " s"
                              : "its step of " + num(c.change, 6) + " " + s.unit + " at t0 = " + num(c.t0) + " s";
  throw Error(PKM_ERR_PARAMETER, "parameter " + s.name + " = " + num(v, 10) + " " + s.unit + " at t = " + num(t) +
                                     " s (" + how + ") is outside its valid range [" + num(s.lo) + ", " +
                                     num(s.hi) + "]");
}

namespace {

// Why parameter i cannot have a course of this kind ("" if it can).
std::string refusal(const pkm_model* m, int i, int kind) {
  const std::string& name = m->specs[i].name;
  for (const char* fixed : {"drive.two_body", "actuator.delay", "sensor.delay"})
    if (name == fixed) return name + " is read when a sim is created and cannot change with time";
  for (int j = 0; j < m->robot->ndof(); ++j)
    for (bool up : {false, true})
      if (m->robot->joint_limit_param(j, up) == name)
        return name + " is a joint limit (a stop of the integrator) and cannot change with time";
  if (kind == PKM_COURSE_TREND && pkm_param_in_drive_layer(m, i) != 1)
    return "a trend needs a drive-layer parameter (friction, offset, joint force, rotor inertia): " + name +
           " belongs to the mechanism, which is compiled; give it a step instead";
  return "";
}

const Course* find(const pkm_model* m, int i) {
  for (const auto& c : m->courses)
    if (c.param == i) return &c;
  return nullptr;
}

}  // namespace
}  // namespace pkm

using pkm::Error;

extern "C" {

int pkm_param_set_course(pkm_model* m, int i, int kind, double change, double t0, char* err, size_t errlen) {
  return pkm::guard_err(err, errlen, [&] {
    PKM_REQUIRE(m != nullptr, PKM_ERR_ARGUMENT, "model is NULL");
    PKM_REQUIRE(i >= 0 && i < (int)m->specs.size(), PKM_ERR_ARGUMENT,
                "course: parameter index " + std::to_string(i) + " out of range [0, " +
                    std::to_string(m->specs.size()) + ")");
    const auto& s = m->specs[i];
    PKM_REQUIRE(kind == PKM_COURSE_NONE || kind == PKM_COURSE_TREND || kind == PKM_COURSE_STEP, PKM_ERR_ARGUMENT,
                "course of " + s.name + ": unknown kind " + std::to_string(kind) +
                    " (PKM_COURSE_NONE 0, PKM_COURSE_TREND 1, PKM_COURSE_STEP 2)");
    PKM_REQUIRE(std::isfinite(change), PKM_ERR_ARGUMENT,
                "course of " + s.name + ": the " + (kind == PKM_COURSE_STEP ? "step size " : "rate ") +
                    pkm::num(change) + " is not finite");
    PKM_REQUIRE(std::isfinite(t0) && t0 >= 0, PKM_ERR_ARGUMENT,
                "course of " + s.name + ": t0 = " + pkm::num(t0) + " s must be finite and >= 0 (a sim's time)");
    auto& cs = m->courses;
    for (auto it = cs.begin(); it != cs.end(); ++it)
      if (it->param == i) {
        cs.erase(it);
        break;
      }
    if (kind == PKM_COURSE_NONE) return;
    const std::string why = pkm::refusal(m, i, kind);
    PKM_REQUIRE(why.empty(), PKM_ERR_PARAMETER, "course of " + s.name + ": " + why);
    pkm::Course c{i, kind, change, t0};
    if (kind == PKM_COURSE_STEP) pkm::check_course_value(s, c, m->values[i] + change, t0);
    cs.push_back(c);
  });
}

int pkm_param_course(const pkm_model* m, int i, int* kind, double* change, double* t0) {
  if (!m || i < 0 || i >= (int)m->specs.size()) return PKM_ERR_ARGUMENT;
  const pkm::Course* c = pkm::find(m, i);
  if (kind) *kind = c ? c->kind : PKM_COURSE_NONE;
  if (change) *change = c ? c->change : 0.0;
  if (t0) *t0 = c ? c->t0 : 0.0;
  return PKM_OK;
}

int pkm_param_value_at(const pkm_model* m, int i, double t, double* value) {
  if (!m || !value || i < 0 || i >= (int)m->specs.size() || !std::isfinite(t)) return PKM_ERR_ARGUMENT;
  const pkm::Course* c = pkm::find(m, i);
  *value = c ? pkm::course_value(*c, m->values[i], t) : m->values[i];
  return PKM_OK;
}

}  // extern "C"
