// C API: models, data and named parameters.
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <sstream>

#include "common/guard.hpp"
#include "description/described_robot.hpp"
#include "dynamics/drive.hpp"

using pkm::Error;

namespace pkm {

[[noreturn]] void unsupported(const Robot& r, const char* what) {
  throw Error(PKM_ERR_UNSUPPORTED, std::string("robot '") + r.name() + "' does not provide " + what);
}

const RobotModel& prepare(const pkm_model* m, pkm_data* d) {
  if (!m) throw Error(PKM_ERR_ARGUMENT, "model is NULL");
  if (d->robot != m->robot)
    throw Error(PKM_ERR_ARGUMENT, "data was created for robot '" + std::string(d->robot->name()) +
                                      "', not for this '" + m->robot_name + "' model");
  if (!m->compiled)
    throw Error(PKM_ERR_PARAMETER,
                "model parameters were changed and not validated: call pkm_model_validate");
  if (d->rd_for != m->compiled.get()) {
    d->rd = m->robot->make_data(*m->compiled);
    d->rd_for = m->compiled.get();
    d->keep = m->compiled;
  }
  return *m->compiled;
}

}  // namespace pkm

extern "C" {

const char* pkm_status_name(int s) {
  switch (s) {
    case PKM_OK: return "PKM_OK";
    case PKM_ERR_ARGUMENT: return "PKM_ERR_ARGUMENT";
    case PKM_ERR_PARAMETER: return "PKM_ERR_PARAMETER";
    case PKM_ERR_UNREACHABLE: return "PKM_ERR_UNREACHABLE";
    case PKM_ERR_SINGULAR: return "PKM_ERR_SINGULAR";
    case PKM_ERR_NO_CONVERGENCE: return "PKM_ERR_NO_CONVERGENCE";
    case PKM_ERR_JOINT_LIMIT: return "PKM_ERR_JOINT_LIMIT";
    case PKM_ERR_INTEGRATION: return "PKM_ERR_INTEGRATION";
    case PKM_ERR_UNSUPPORTED: return "PKM_ERR_UNSUPPORTED";
    case PKM_ERR_INTERNAL: return "PKM_ERR_INTERNAL";
    default: return "PKM_ERR_UNKNOWN";
  }
}

pkm_model* pkm_model_create(const char* robot, const char* param_set, char* err, size_t errlen) {
  pkm_model* out = nullptr;
  pkm_model_create_status(robot, param_set, &out, err, errlen);
  return out;
}

int pkm_model_create_status(const char* robot, const char* param_set, pkm_model** result, char* err,
                            size_t errlen) {
  pkm_model* out = nullptr;
  const int status = pkm::guard_err(err, errlen, [&] {
    PKM_REQUIRE(robot != nullptr, PKM_ERR_ARGUMENT, "robot name is NULL");
    const pkm::Robot* r = pkm::find_robot(robot);
    PKM_REQUIRE(r != nullptr, PKM_ERR_ARGUMENT,
                 std::string("unknown robot '") + robot + "' (known: " + pkm::known_robots() + ")");
    auto m = std::make_unique<pkm_model>();
    m->robot = r;
    m->robot_name = r->name();
    m->specs = r->param_specs(param_set ? param_set : "default");
    // the force on the platform is the mechanism's (a load like gravity), before the drive layer's
    for (auto& s : pkm::platform_force::specs(*r)) m->specs.push_back(std::move(s));
    for (auto& s : pkm::drive::specs(*r)) m->specs.push_back(std::move(s));
    for (const auto& o : r->param_overrides(param_set ? param_set : "default"))
      for (auto& s : m->specs)
        if (s.name == o.first) s.value = o.second;
    for (const auto& s : m->specs) m->values.push_back(s.value);
    for (int i = 0; i < r->ndof(); ++i)
      for (int up = 0; up < 2; ++up) {
        const std::string name = r->joint_limit_param(i, up != 0);
        m->joint_limit_index.push_back(name.empty() ? -1 : pkm_param_index(m.get(), name.c_str()));
      }
    m->compiled = std::shared_ptr<const pkm::RobotModel>(r->compile(m->specs, m->values));
    m->drive = pkm::drive::compile(*r, m->specs, m->values);
    out = m.release();
  });
  if (result) *result = out;
  else pkm_model_destroy(out);
  return status;
}

int pkm_robot_count(void) { return pkm::robot_count(); }

const char* pkm_robot_name(int i) { return pkm::robot_name_at(i); }

namespace {
// Parameter-set names per robot, kept for the life of the process (the C strings the
// API hands out point into it).
const std::vector<std::string>* param_sets_of(const char* robot) {
  static std::mutex mu;
  static std::map<const pkm::Robot*, std::vector<std::string>> sets;
  if (!robot) return nullptr;
  const pkm::Robot* r = nullptr;
  try {
    r = pkm::find_robot(robot);
  } catch (const pkm::Error&) {
    return nullptr;
  }
  if (!r) return nullptr;
  std::lock_guard<std::mutex> lock(mu);
  auto it = sets.find(r);
  if (it == sets.end()) it = sets.emplace(r, r->param_sets()).first;
  return &it->second;
}
}  // namespace

namespace {
const pkm::Robot* robot_or_null(const char* robot) {
  if (!robot) return nullptr;
  try {
    return pkm::find_robot(robot);
  } catch (const pkm::Error&) {
    return nullptr;
  }
}
}  // namespace

int pkm_robot_register_description(const char* text, const char* file, char* err, size_t errlen) {
  return pkm::guard_err(err, errlen, [&] {
    PKM_REQUIRE(text != nullptr, PKM_ERR_ARGUMENT, "description text is NULL");
    pkm::described::register_description(text, file ? file : "<description>");
  });
}

const char* pkm_robot_title(const char* robot) {
  const pkm::Robot* r = robot_or_null(robot);
  return r ? r->title() : "";
}

const char* pkm_robot_file(const char* robot) {
  const pkm::Robot* r = robot_or_null(robot);
  return r ? r->source_file() : "";
}

int pkm_robot_param_set_count(const char* robot) {
  const auto* s = param_sets_of(robot);
  return s ? (int)s->size() : -1;
}

const char* pkm_robot_param_set_name(const char* robot, int i) {
  const auto* s = param_sets_of(robot);
  return s && i >= 0 && i < (int)s->size() ? (*s)[i].c_str() : "";
}

const char* pkm_model_pose_name(const pkm_model* m, int i) {
  return m && i >= 0 && i < m->robot->ndof() ? m->robot->pose_name(i) : "";
}
const char* pkm_model_pose_unit(const pkm_model* m, int i) {
  return m && i >= 0 && i < m->robot->ndof() ? m->robot->pose_unit(i) : "";
}
int pkm_model_tracker_count(const pkm_model* m) { return m ? m->robot->tracker_count() : -1; }
const char* pkm_model_tracker_name(const pkm_model* m, int i) {
  return m && i >= 0 && i < m->robot->tracker_count() ? m->robot->tracker_name(i) : "";
}
const char* pkm_model_tracker_unit(const pkm_model* m, int i) {
  return m && i >= 0 && i < m->robot->tracker_count() ? m->robot->tracker_unit(i) : "";
}
const char* pkm_model_geometry_param(const pkm_model* m, int i) {
  if (!m || i < 0) return "";
  const char* n = m->robot->geometry_param(i);
  return n ? n : "";
}
const char* pkm_model_joint_unit(const pkm_model* m) { return m ? (m->robot->joints_angular() ? "rad" : "m") : ""; }
const char* pkm_model_effort_unit(const pkm_model* m) { return m ? (m->robot->joints_angular() ? "N m" : "N") : ""; }
int pkm_model_feature_count(const pkm_model* m) {
  return m ? static_cast<int>(pkm::robot_features(*m->robot).size()) : 0;
}
const char* pkm_model_feature(const pkm_model* m, int i) {
  if (!m || i < 0) return "";
  const auto f = pkm::robot_features(*m->robot);
  return i < static_cast<int>(f.size()) ? f[static_cast<size_t>(i)] : "";
}
int pkm_model_has(const pkm_model* m, const char* feature) {
  if (!m || !feature) return 0;
  for (const char* f : pkm::robot_features(*m->robot))
    if (std::strcmp(f, feature) == 0) return 1;
  return 0;
}
const char* pkm_model_joint_noun(const pkm_model* m) { return m ? m->robot->joint_noun() : ""; }
const char* pkm_model_joint_prefix(const pkm_model* m) { return m ? m->robot->joint_prefix() : ""; }

int pkm_model_joint_limits(const pkm_model* m, int i, int* lower, int* upper) {
  if (!m || i < 0 || i >= m->robot->ndof()) return PKM_ERR_ARGUMENT;
  if (lower) *lower = m->joint_limit_index[2 * (size_t)i];
  if (upper) *upper = m->joint_limit_index[2 * (size_t)i + 1];
  return PKM_OK;
}

pkm_model* pkm_model_copy(const pkm_model* m) {
  if (!m) return nullptr;
  try {
    return new pkm_model(*m);
  } catch (...) {
    return nullptr;
  }
}

void pkm_model_destroy(pkm_model* m) { delete m; }

const char* pkm_model_robot(const pkm_model* m) { return m ? m->robot_name.c_str() : ""; }
int pkm_model_ndof(const pkm_model* m) { return m ? m->robot->ndof() : 0; }
int pkm_model_nparam(const pkm_model* m) { return m ? (int)m->specs.size() : 0; }

int pkm_param_index(const pkm_model* m, const char* name) {
  if (!m || !name) return -1;
  for (size_t i = 0; i < m->specs.size(); ++i)
    if (m->specs[i].name == name) return (int)i;
  return -1;
}

static bool valid_index(const pkm_model* m, int i) { return m && i >= 0 && i < (int)m->specs.size(); }

const char* pkm_param_name(const pkm_model* m, int i) { return valid_index(m, i) ? m->specs[i].name.c_str() : ""; }
const char* pkm_param_unit(const pkm_model* m, int i) { return valid_index(m, i) ? m->specs[i].unit.c_str() : ""; }
const char* pkm_param_description(const pkm_model* m, int i) {
  return valid_index(m, i) ? m->specs[i].description.c_str() : "";
}
double pkm_param_get(const pkm_model* m, int i) { return valid_index(m, i) ? m->values[i] : std::nan(""); }

int pkm_param_in_drive_layer(const pkm_model* m, int i) {
  if (!valid_index(m, i)) return -1;
  // the drive layer's parameters follow the robot's (pkm_model_create appends them)
  return static_cast<size_t>(i) + pkm::drive::specs(*m->robot).size() >= m->specs.size() ? 1 : 0;
}

int pkm_param_set(pkm_model* m, int i, double value, char* err, size_t errlen) {
  return pkm::guard_err(err, errlen, [&] {
    PKM_REQUIRE(m != nullptr, PKM_ERR_ARGUMENT, "model is NULL");
    PKM_REQUIRE(valid_index(m, i), PKM_ERR_ARGUMENT,
                 "parameter index " + std::to_string(i) + " out of range [0, " +
                     std::to_string(m->specs.size()) + ")");
    const auto& s = m->specs[i];
    std::ostringstream os;
    os.precision(17);
    if (!std::isfinite(value) || value < s.lo || value > s.hi) {
      os << "parameter " << s.name << " = " << value << " " << s.unit << " is outside its valid range ["
         << s.lo << ", " << s.hi << "]";
      throw Error(PKM_ERR_PARAMETER, os.str());
    }
    m->values[i] = value;
    m->compiled.reset();
  });
}

int pkm_model_validate(pkm_model* m, char* err, size_t errlen) {
  return pkm::guard_err(err, errlen, [&] {
    PKM_REQUIRE(m != nullptr, PKM_ERR_ARGUMENT, "model is NULL");
    m->compiled = std::shared_ptr<const pkm::RobotModel>(m->robot->compile(m->specs, m->values));
    m->drive = pkm::drive::compile(*m->robot, m->specs, m->values);
  });
}

int pkm_model_home(const pkm_model* m, double* x) {
  if (!m || !x || !m->compiled) return m && x ? PKM_ERR_PARAMETER : PKM_ERR_ARGUMENT;
  std::string sink;
  return pkm::guard_into(sink, [&] { m->robot->home(*m->compiled, x); });
}

pkm_data* pkm_data_create(const pkm_model* m) {
  if (!m) return nullptr;
  try {
    auto d = std::make_unique<pkm_data>();
    d->robot = m->robot;
    d->ndof = m->robot->ndof();
    if (m->compiled) {
      d->rd = m->robot->make_data(*m->compiled);
      d->rd_for = m->compiled.get();
      d->keep = m->compiled;
    }
    return d.release();
  } catch (...) {
    return nullptr;
  }
}

void pkm_data_destroy(pkm_data* d) { delete d; }

int pkm_data_check(const pkm_model* m, const pkm_data* d) {
  if (!m || !d) return PKM_ERR_ARGUMENT;
  return (d->robot == m->robot && d->ndof == m->robot->ndof()) ? PKM_OK : PKM_ERR_ARGUMENT;
}

const char* pkm_data_error(const pkm_data* d) { return d ? d->error.c_str() : "data is NULL"; }

}  // extern "C"
