// fmu_gen's reading of a model folder's variables.txt: the @ lines, the variable rows (families
// expanded), the core's parameters and joint limits, and the check that the table describes
// a complete model.
#include <algorithm>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "fmu_gen.hpp"

namespace fmu_gen {

// Channel name -> (is Integer); the model's enum is fmu_channel in fmu_model.h.
const std::map<std::string, std::pair<std::string, bool>>& channels() {
  static const std::map<std::string, std::pair<std::string, bool>> c = {
      {"param", {"FMU_CH_PARAM", false}},
      {"tau", {"FMU_CH_TAU", false}},
      {"pose", {"FMU_CH_POSE", false}},
      {"twist", {"FMU_CH_TWIST", false}},
      {"accel", {"FMU_CH_ACCEL", false}},
      {"q", {"FMU_CH_Q", false}},
      {"qd", {"FMU_CH_QD", false}},
      {"pose0", {"FMU_CH_POSE0", false}},
      {"twist0", {"FMU_CH_TWIST0", false}},
      {"sing", {"FMU_CH_SING", false}},
      {"energy", {"FMU_CH_ENERGY", false}},
      {"solver.method", {"FMU_CH_SOLVER_METHOD", true}},
      {"solver.rtol", {"FMU_CH_SOLVER_RTOL", false}},
      {"solver.atol", {"FMU_CH_SOLVER_ATOL", false}},
      {"solver.maxStep", {"FMU_CH_SOLVER_MAX_STEP", false}},
      {"solver.maxSteps", {"FMU_CH_SOLVER_MAX_STEPS", true}},
      {"solver.singMin", {"FMU_CH_SOLVER_SING_MIN", false}},
      {"input.gain", {"FMU_CH_INPUT_GAIN", false}},
      {"q_drive", {"FMU_CH_Q_DRIVE", false}},
      {"qd_drive", {"FMU_CH_QD_DRIVE", false}},
      // controller FMUs (@kind controller): readings and reference in, effort out, the law
      {"ctrl.q", {"FMU_CH_CTRL_Q", false}},
      {"ctrl.qd", {"FMU_CH_CTRL_QD", false}},
      {"ctrl.qref", {"FMU_CH_CTRL_QREF", false}},
      {"ctrl.qdref", {"FMU_CH_CTRL_QDREF", false}},
      {"ctrl.qddref", {"FMU_CH_CTRL_QDDREF", false}},
      {"ctrl.tau", {"FMU_CH_CTRL_TAU", false}},
      {"ctrl.kind", {"FMU_CH_CTRL_KIND", true}},
      {"ctrl.dt", {"FMU_CH_CTRL_DT", false}},
      {"ctrl.kp", {"FMU_CH_CTRL_KP", false}},
      {"ctrl.kd", {"FMU_CH_CTRL_KD", false}},
      {"ctrl.ki", {"FMU_CH_CTRL_KI", false}},
      {"ctrl.tf", {"FMU_CH_CTRL_TF", false}},
      {"ctrl.saturation", {"FMU_CH_CTRL_SAT", false}},
      {"ctrl.gravityAtReference", {"FMU_CH_CTRL_GRAVITY_REF", true}},
      {"ctrl.gravityFeedforward", {"FMU_CH_CTRL_GRAVITY_FF", true}},
      {"ctrl.nx", {"FMU_CH_CTRL_NX", true}},
      {"ctrl.A", {"FMU_CH_CTRL_A", false}},
      {"ctrl.B", {"FMU_CH_CTRL_B", false}},
      {"ctrl.C", {"FMU_CH_CTRL_C", false}},
      {"ctrl.D", {"FMU_CH_CTRL_D", false}},
  };
  return c;
}

namespace {

// Where the reading is (the file, its line) and what the @robot line gave: the core model's
// joints and home pose, the core's default solver settings (the solver.* start values).
struct Reader {
  std::string path;
  int ln = 0, nd = 0;
  std::vector<double> home;
  pkm_sim_options so;
  std::string where() const { return path + ":" + std::to_string(ln) + ": "; }
};

// @core-parameters: one parameter row per core parameter, from the core's table.
void add_core_parameters(Table& t, pkm_model* model) {
  for (int i = 0; i < pkm_model_nparam(model); ++i) {
    Var v;
    v.name = pkm_param_name(model, i);
    v.causality = "parameter";
    v.channel = "param";
    v.index = i;
    v.unit = pkm_param_unit(model, i);
    v.description = pkm_param_description(model, i);
    v.has_start = true;
    v.start = pkm_param_get(model, i);
    t.vars.push_back(v);
  }
}

// @robot <name or description file>: the core model (and the description's text).
void read_robot(Table& t, const std::string& val, pkm_model*& model, Reader& r) {
  char err[1024] = "";
  const char* set = t.head.count("paramset") ? t.head["paramset"].c_str() : nullptr;
  model = pkm_model_create(val.c_str(), set, err, sizeof err);
  if (!model) throw Fail(r.where() + "robot '" + val + "': " + err);
  // A robot from a description (docs/robots.md), given as a file or served by name
  // (robots/6pus.toml for "6pus"): the FMU carries its text and compiles it when
  // instantiated, so the binary needs no file and no code of the robot.
  const std::string file = pkm_robot_file(val.c_str());
  if (!file.empty()) {
    std::ifstream df(file);
    if (!df) throw Fail(r.where() + "cannot read the description " + file + " of robot '" + val + "'");
    std::stringstream ds;
    ds << df.rdbuf();
    t.description = ds.str();
  }
  t.robot_name = pkm_model_robot(model);
  r.nd = pkm_model_ndof(model);
  r.home.assign(r.nd, 0.0);
  int st = pkm_model_home(model, r.home.data());
  if (st != PKM_OK) throw Fail(r.where() + "the core has no home pose for '" + val + "'");
}

// One "@key value" line.
void read_head(Table& t, const std::string& s, pkm_model*& model, Reader& r) {
  size_t sp = s.find_first_of(" \t");
  std::string key = sp == std::string::npos ? s.substr(1) : s.substr(1, sp - 1);
  std::string val = sp == std::string::npos ? "" : trim(s.substr(sp));
  if (key == "core-parameters") {
    if (!model) throw Fail(r.where() + "@core-parameters before @robot");
    add_core_parameters(t, model);
    t.head[key] = "1";
    return;
  }
  t.head[key] = val;
  if (key == "lti-states") t.nx = std::stoi(val);
  if (key == "robot") read_robot(t, val, model, r);
}

// The start value of a parameter row of channel cname (entry index).
double parameter_start(const std::string& cname, int index, const Table& t, const Reader& r) {
  if (cname == "pose0") return r.home.at(index);
  if (cname == "twist0") return 0.0;
  if (cname == "solver.method") return r.so.method;
  if (cname == "solver.rtol") return r.so.rtol;
  if (cname == "solver.atol") return r.so.atol;
  if (cname == "solver.maxStep") return r.so.max_step;
  if (cname == "solver.maxSteps") return (double)r.so.max_steps;
  if (cname == "solver.singMin") return r.so.sing_min;
  if (cname == "input.gain") return 1.0;
  if (cname == "ctrl.dt") return 1e-3;
  if (cname == "ctrl.nx") return t.nx;
  if (cname.rfind("ctrl.", 0) == 0) return 0.0;  // gains, matrices, flags: set by the user
  throw Fail(r.where() + "channel '" + cname + "' cannot be a parameter");
}

// A family names its entries with placeholders: {i} and {j} run over the joints, {r}
// and {c} over the LTI states, {p} over the pose coordinates (replaced by their names:
// x, rz, ...); the channel index is the entries' row-major position.  In the unit and
// description, {u} is the pose coordinate's unit, {qu} / {eu} the joints' / efforts'.
// The placeholders of name, each with its count.
std::vector<std::pair<std::string, int>> placeholders(const std::string& name, const Table& t, const Reader& r) {
  std::vector<std::pair<std::string, int>> ph;
  for (size_t p = name.find('{'); p != std::string::npos; p = name.find('{', p + 1)) {
    const std::string tok = name.substr(p, 3);
    if (tok == "{i}" || tok == "{j}" || tok == "{p}") ph.push_back({tok, r.nd});
    else if (tok == "{r}" || tok == "{c}") ph.push_back({tok, t.nx});
    else throw Fail(r.where() + "unknown placeholder in '" + name + "' (use {i}, {j}, {p}, {r}, {c})");
  }
  return ph;
}

// Entry k of a family row (or the single entry of a plain row): its name, unit and
// description with the placeholders replaced.
void name_entry(Var& v, int k, const std::vector<std::pair<std::string, int>>& ph, const std::string& unit,
                pkm_model* model) {
  int rest = k;
  for (size_t a = ph.size(); a-- > 0;) {
    const int pos = rest % ph[a].second;
    rest /= ph[a].second;
    const std::string label = ph[a].first == "{p}" ? pkm_model_pose_name(model, pos) : std::to_string(pos + 1);
    v.name = replace_all(v.name, ph[a].first, label);
    v.description = replace_all(v.description, ph[a].first, label);
    if (ph[a].first == "{p}") {
      v.unit = replace_all(unit, "{u}", pkm_model_pose_unit(model, pos));
      v.description = replace_all(v.description, "{u}", pkm_model_pose_unit(model, pos));
    }
  }
  if (v.unit.empty()) v.unit = unit;
  for (auto* s : {&v.unit, &v.description}) {
    *s = replace_all(*s, "{qu}", pkm_model_joint_unit(model));
    *s = replace_all(*s, "{eu}", pkm_model_effort_unit(model));
  }
}

// One variable row "causality | name | channel | unit | description": one entry, or one
// per member of a family.
void read_row(Table& t, const std::string& s, pkm_model* model, const Reader& r) {
  auto f = split(s, '|');
  if (f.size() != 5) throw Fail(r.where() + "expected 'causality | name | channel | unit | description'");
  std::string caus = f[0], name = f[1], chan = f[2];
  if (caus != "input" && caus != "output" && caus != "parameter")
    throw Fail(r.where() + "causality '" + caus + "' (use input, output or parameter)");
  // "pose[3]" -> channel pose, index 3; "q" with a {i} name -> family.
  std::string cname = chan;
  int cindex = -1;
  size_t lb = chan.find('[');
  if (lb != std::string::npos) {
    cname = chan.substr(0, lb);
    cindex = std::stoi(chan.substr(lb + 1));
  }
  auto ci = channels().find(cname);
  if (ci == channels().end() || cname == "param") throw Fail(r.where() + "unknown channel '" + chan + "'");
  const std::vector<std::pair<std::string, int>> ph = placeholders(name, t, r);
  bool family = !ph.empty();
  if (family && cindex >= 0) throw Fail(r.where() + "a family takes the channel without an index");
  if (!family && cindex < 0) cindex = 0;  // single-valued channels (solver.*)
  int n = 1;
  for (const auto& q : ph) n *= q.second;
  for (int k = 0; k < n; ++k) {
    Var v;
    v.causality = caus;
    v.channel = cname;
    v.index = family ? k : cindex;
    v.integer = ci->second.second;
    v.name = name;
    v.description = f[4];
    v.line = r.ln;
    if (family) {
      for (const auto& q : ph) v.dims.push_back(q.second);
      v.family_name = name.substr(0, name.find('['));
      v.family_description = f[4];
    }
    name_entry(v, k, ph, f[3], model);
    if (caus == "input") {
      v.has_start = true;
      v.start = 0.0;
    } else if (caus == "parameter") {
      v.has_start = true;
      v.start = parameter_start(cname, v.index, t, r);
    }
    t.vars.push_back(v);
  }
}

// @joint-limits: the core parameter numbers of each joint's lower and upper limit, from
// the core ("core") or from two parameter names with {i}.
void read_joint_limits(Table& t, pkm_model* model, int nd, const std::string& path) {
  auto f = split(replace_all(t.head["joint-limits"], "\t", " "), ' ');
  f.erase(std::remove(f.begin(), f.end(), std::string()), f.end());
  if (f.size() == 1 && f[0] == "core") {
    // The core's own fact (pkm_model_joint_limits): the table does not restate the names.
    // A robot whose joints have none (a continuous axis, docs/robots.md) gets no limit events.
    for (int k = 0; k < nd; ++k) {
      int lo = -1, hi = -1;
      if (pkm_model_joint_limits(model, k, &lo, &hi) != PKM_OK) lo = hi = -1;
      if (lo < 0 && hi < 0 && t.qmin.empty()) continue;
      if (lo < 0 || hi < 0 || (k > 0 && t.qmin.empty()))
        throw Fail(path + ": @joint-limits core: the robot declares limit parameters for some joints only (joint " +
                   std::to_string(k + 1) + "): the FMU's limit events are per joint, all or none");
      t.qmin.push_back(lo);
      t.qmax.push_back(hi);
    }
    return;
  }
  if (f.size() != 2) throw Fail(path + ": @joint-limits needs 'core' or two parameter names with {i} (lower, upper)");
  for (int k = 0; k < nd; ++k)
    for (int w = 0; w < 2; ++w) {
      std::string name = replace_all(f[w], "{i}", std::to_string(k + 1));
      int idx = pkm_param_index(model, name.c_str());
      if (idx < 0) throw Fail(path + ": @joint-limits: the core has no parameter '" + name + "'");
      (w ? t.qmax : t.qmin).push_back(idx);
    }
}

}  // namespace

Table read_table(const std::string& path, pkm_model*& model) {
  std::ifstream in(path);
  if (!in) throw Fail(path + ": cannot open");
  Table t;
  Reader r;
  r.path = path;
  pkm_sim_default_options(&r.so);
  std::string line;
  while (std::getline(in, line)) {
    ++r.ln;
    std::string s = trim(line);
    if (s.empty() || s[0] == '#') continue;
    if (s[0] == '@') {
      read_head(t, s, model, r);
      continue;
    }
    if (!model) throw Fail(r.where() + "variable rows need @robot first");
    read_row(t, s, model, r);
  }
  for (const char* k : {"identifier", "robot", "core-parameters"})
    if (!t.head.count(k)) throw Fail(path + ": missing @" + std::string(k));
  if (t.head.count("joint-limits")) read_joint_limits(t, model, r.nd, path);
  return t;
}

// Checks that the table describes a complete model: each state, derivative and input
// exactly once, names unique.
void check(const Table& t, int nd, const std::string& path) {
  std::set<std::string> names;
  std::map<std::pair<std::string, int>, int> seen;
  for (const auto& v : t.vars) {
    if (!names.insert(v.name).second) throw Fail(path + ": variable name '" + v.name + "' used twice");
    if (++seen[{v.channel, v.index}] > 1 && v.channel != "param")
      throw Fail(path + ": channel " + v.channel + "[" + std::to_string(v.index) + "] used twice");
  }
  if (t.controller()) {
    for (const char* ch : {"ctrl.q", "ctrl.qd", "ctrl.qref", "ctrl.qdref", "ctrl.qddref", "ctrl.tau", "ctrl.saturation"})
      for (int k = 0; k < nd; ++k)
        if (!seen.count({ch, k}))
          throw Fail(path + ": channel " + std::string(ch) + "[" + std::to_string(k) + "] is missing");
    for (const auto& v : t.vars) {
      const bool in = v.channel == "ctrl.q" || v.channel == "ctrl.qd" || v.channel == "ctrl.qref" ||
                      v.channel == "ctrl.qdref" || v.channel == "ctrl.qddref";
      if (in != (v.causality == "input")) throw Fail(path + ": " + v.name + ": inputs are the readings and the reference");
      if ((v.channel == "ctrl.tau") != (v.causality == "output")) throw Fail(path + ": " + v.name + ": the output is tau");
      if (v.channel.rfind("ctrl.", 0) != 0 && v.channel != "param")
        throw Fail(path + ": " + v.name + ": a controller FMU has no channel " + v.channel);
    }
    return;
  }
  for (const char* ch : {"tau", "pose", "twist", "accel", "pose0", "twist0"})
    for (int k = 0; k < nd; ++k)
      if (!seen.count({ch, k}))
        throw Fail(path + ": channel " + std::string(ch) + "[" + std::to_string(k) + "] is missing");
  for (const char* ch : {"solver.method", "solver.rtol", "solver.atol", "solver.maxStep", "solver.maxSteps",
                         "solver.singMin"})
    if (!seen.count({ch, 0})) throw Fail(path + ": channel " + std::string(ch) + " is missing");
  for (const auto& v : t.vars) {
    if ((v.channel == "tau") != (v.causality == "input"))
      throw Fail(path + ": " + v.name + ": inputs are the tau channel, and only inputs");
    if ((v.channel == "pose" || v.channel == "twist" || v.channel == "accel" || v.channel == "q" ||
         v.channel == "qd" || v.channel == "q_drive" || v.channel == "qd_drive" || v.channel == "sing" ||
         v.channel == "energy") != (v.causality == "output"))
      throw Fail(path + ": " + v.name + ": causality " + v.causality + " does not fit channel " + v.channel);
    if (v.channel == "sing" && (v.index < 0 || v.index > 1)) throw Fail(path + ": " + v.name + ": sing index 0 or 1");
    if (v.channel == "energy" && (v.index < 0 || v.index > 1))
      throw Fail(path + ": " + v.name + ": energy index 0 or 1");
    if (v.index < 0 || v.index >= nd) {
      bool small = v.channel == "sing" || v.channel == "energy" || v.channel == "param" ||
                   v.channel.rfind("solver.", 0) == 0;
      if (!small) throw Fail(path + ": " + v.name + ": index " + std::to_string(v.index) + " out of range");
    }
  }
}

}  // namespace fmu_gen
