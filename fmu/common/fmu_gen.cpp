// fmu_gen -- writes an FMU's modelDescription.xml AND the C table of its value
// references (fmu_vars.h) from one source: the model folder's variables.txt plus the
// core's own parameter table (names, units, descriptions, defaults come from pkm.h, they
// are not declared twice).  Run by CMake at build time; see docs/fmu.md.
//
//   fmu_gen <variables.txt> <modelDescription.xml> <fmu_vars.h> [<source md.xml> <source file>...]
//
// Exit status 0 on success; otherwise a message naming the file and line on stderr.
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "pkm/pkm.h"

namespace {

struct Fail : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Var {
  std::string name, causality, channel, unit, description;
  int index = 0;       // within the channel
  bool integer = false;
  bool has_start = false;
  double start = 0;
  // The table line the row comes from and, for a family, its dimensions ({i} ... each one
  // a dimension) and its name and description as written: an FMI 3.0 array.
  int line = 0;
  std::vector<int> dims;
  std::string family_name, family_description;
};

std::string trim(const std::string& s) {
  size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  std::istringstream is(s);
  while (std::getline(is, cur, sep)) out.push_back(trim(cur));
  return out;
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) s.replace(p, from.size(), to);
  return s;
}

std::string xml(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string cstr(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '\n') {
      o += "\\n\" \\\n    \"";  // a long text as one literal per line (it may be a macro's)
      continue;
    }
    if (c == '"' || c == '\\') o += '\\';
    o += c;
  }
  return o + "\"";
}

std::string num(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

// Dimensionless quantities carry no unit attribute.
bool no_unit(const std::string& u) { return u.empty() || u == "1" || u == "-"; }

// SI base-unit exponents of a unit string such as "m/s2", "kg.m2", "N.s/m", "kg m^2".
// Returns false for a unit it cannot read (written without BaseUnit then).
bool base_unit(const std::string& unit, std::map<std::string, int>& exps) {
  static const std::map<std::string, std::map<std::string, int>> sym = {
      {"m", {{"m", 1}}},   {"kg", {{"kg", 1}}}, {"s", {{"s", 1}}},  {"A", {{"A", 1}}}, {"K", {{"K", 1}}},
      {"mol", {{"mol", 1}}}, {"cd", {{"cd", 1}}}, {"rad", {{"rad", 1}}},
      {"N", {{"kg", 1}, {"m", 1}, {"s", -2}}},   {"J", {{"kg", 1}, {"m", 2}, {"s", -2}}},
      {"W", {{"kg", 1}, {"m", 2}, {"s", -3}}},   {"Pa", {{"kg", 1}, {"m", -1}, {"s", -2}}},
      {"Hz", {{"s", -1}}}};
  std::string u = unit;
  int sign = 1;
  std::string tok;
  auto flush = [&]() -> bool {
    if (tok.empty()) return true;
    size_t k = 0;
    while (k < tok.size() && std::isalpha((unsigned char)tok[k])) ++k;
    std::string s = tok.substr(0, k), e = tok.substr(k);
    if (!e.empty() && e[0] == '^') e = e.substr(1);
    int p = 1;
    if (!e.empty()) {
      try {
        size_t used = 0;
        p = std::stoi(e, &used);
        if (used != e.size()) return false;
      } catch (...) {
        return false;
      }
    }
    auto it = sym.find(s);
    if (it == sym.end()) return false;
    for (auto& kv : it->second) exps[kv.first] += sign * p * kv.second;
    tok.clear();
    return true;
  };
  for (char c : u) {
    if (c == '.' || c == '*' || c == ' ') {
      if (!flush()) return false;
    } else if (c == '/') {
      if (!flush() || sign < 0) return false;  // one '/' at most
      sign = -1;
    } else {
      tok += c;
    }
  }
  return flush();
}

struct Table {
  std::map<std::string, std::string> head;
  std::vector<Var> vars;
  std::vector<int> qmin, qmax;  // core parameter numbers per joint (@joint-limits), or empty
  int nx = 0;                   // controller FMUs: states of the LTI law (@lti-states)
  std::string robot_name;       // the core's name of @robot (a description file's robot.name)
  std::string description;      // @robot given as a description file: its text, packed into the FMU
  bool controller() const { return head.count("kind") && head.at("kind") == "controller"; }
  int nindicators() const { return controller() ? 0 : 1 + (qmin.empty() ? 0 : 2 * (int)qmin.size()); }
};

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

Table read_table(const std::string& path, pkm_model*& model) {
  std::ifstream in(path);
  if (!in) throw Fail(path + ": cannot open");
  Table t;
  std::string line;
  int ln = 0, nd = 0;
  std::vector<double> home;
  pkm_sim_options so;
  pkm_sim_default_options(&so);
  auto where = [&] { return path + ":" + std::to_string(ln) + ": "; };
  while (std::getline(in, line)) {
    ++ln;
    std::string s = trim(line);
    if (s.empty() || s[0] == '#') continue;
    if (s[0] == '@') {
      size_t sp = s.find_first_of(" \t");
      std::string key = sp == std::string::npos ? s.substr(1) : s.substr(1, sp - 1);
      std::string val = sp == std::string::npos ? "" : trim(s.substr(sp));
      if (key == "core-parameters") {
        if (!model) throw Fail(where() + "@core-parameters before @robot");
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
        t.head[key] = "1";
        continue;
      }
      t.head[key] = val;
      if (key == "lti-states") t.nx = std::stoi(val);
      if (key == "robot") {
        char err[1024] = "";
        const char* set = t.head.count("paramset") ? t.head["paramset"].c_str() : nullptr;
        model = pkm_model_create(val.c_str(), set, err, sizeof err);
        if (!model) throw Fail(where() + "robot '" + val + "': " + err);
        t.robot_name = pkm_model_robot(model);
        // A robot from a description (docs/robots.md), given as a file or served by name
        // (robots/6pus.toml for "6pus"): the FMU carries its text and compiles it when
        // instantiated, so the binary needs no file and no code of the robot.
        const std::string file = pkm_robot_file(val.c_str());
        if (!file.empty()) {
          std::ifstream df(file);
          if (!df) throw Fail(where() + "cannot read the description " + file + " of robot '" + val + "'");
          std::stringstream ds;
          ds << df.rdbuf();
          t.description = ds.str();
        }
        nd = pkm_model_ndof(model);
        home.assign(nd, 0.0);
        int st = pkm_model_home(model, home.data());
        if (st != PKM_OK) throw Fail(where() + "the core has no home pose for '" + val + "'");
      }
      continue;
    }
    if (!model) throw Fail(where() + "variable rows need @robot first");
    auto f = split(s, '|');
    if (f.size() != 5) throw Fail(where() + "expected 'causality | name | channel | unit | description'");
    std::string caus = f[0], name = f[1], chan = f[2];
    if (caus != "input" && caus != "output" && caus != "parameter")
      throw Fail(where() + "causality '" + caus + "' (use input, output or parameter)");
    // "pose[3]" -> channel pose, index 3; "q" with a {i} name -> family.
    std::string cname = chan;
    int cindex = -1;
    size_t lb = chan.find('[');
    if (lb != std::string::npos) {
      cname = chan.substr(0, lb);
      cindex = std::stoi(chan.substr(lb + 1));
    }
    auto ci = channels().find(cname);
    if (ci == channels().end() || cname == "param") throw Fail(where() + "unknown channel '" + chan + "'");
    // A family names its entries with placeholders: {i} and {j} run over the joints, {r}
    // and {c} over the LTI states, {p} over the pose coordinates (replaced by their names:
    // x, rz, ...); the channel index is the entries' row-major position.  In the unit and
    // description, {u} is the pose coordinate's unit, {qu} / {eu} the joints' / efforts'.
    std::vector<std::pair<std::string, int>> ph;
    for (size_t p = name.find('{'); p != std::string::npos; p = name.find('{', p + 1)) {
      const std::string tok = name.substr(p, 3);
      if (tok == "{i}" || tok == "{j}" || tok == "{p}") ph.push_back({tok, nd});
      else if (tok == "{r}" || tok == "{c}") ph.push_back({tok, t.nx});
      else throw Fail(where() + "unknown placeholder in '" + name + "' (use {i}, {j}, {p}, {r}, {c})");
    }
    bool family = !ph.empty();
    if (family && cindex >= 0) throw Fail(where() + "a family takes the channel without an index");
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
      v.line = ln;
      if (family) {
        for (const auto& q : ph) v.dims.push_back(q.second);
        v.family_name = name.substr(0, name.find('['));
        v.family_description = f[4];
      }
      int rest = k;
      for (size_t a = ph.size(); a-- > 0;) {
        const int pos = rest % ph[a].second;
        rest /= ph[a].second;
        const std::string label = ph[a].first == "{p}" ? pkm_model_pose_name(model, pos) : std::to_string(pos + 1);
        v.name = replace_all(v.name, ph[a].first, label);
        v.description = replace_all(v.description, ph[a].first, label);
        if (ph[a].first == "{p}") {
          v.unit = replace_all(f[3], "{u}", pkm_model_pose_unit(model, pos));
          v.description = replace_all(v.description, "{u}", pkm_model_pose_unit(model, pos));
        }
      }
      if (v.unit.empty()) v.unit = f[3];
      for (auto* s : {&v.unit, &v.description}) {
        *s = replace_all(*s, "{qu}", pkm_model_joint_unit(model));
        *s = replace_all(*s, "{eu}", pkm_model_effort_unit(model));
      }
      if (caus == "input") {
        v.has_start = true;
        v.start = 0.0;
      } else if (caus == "parameter") {
        v.has_start = true;
        if (cname == "pose0") v.start = home.at(v.index);
        else if (cname == "twist0") v.start = 0.0;
        else if (cname == "solver.method") v.start = so.method;
        else if (cname == "solver.rtol") v.start = so.rtol;
        else if (cname == "solver.atol") v.start = so.atol;
        else if (cname == "solver.maxStep") v.start = so.max_step;
        else if (cname == "solver.maxSteps") v.start = (double)so.max_steps;
        else if (cname == "solver.singMin") v.start = so.sing_min;
        else if (cname == "input.gain") v.start = 1.0;
        else if (cname == "ctrl.dt") v.start = 1e-3;
        else if (cname == "ctrl.nx") v.start = t.nx;
        else if (cname.rfind("ctrl.", 0) == 0) v.start = 0.0;  // gains, matrices, flags: set by the user
        else throw Fail(where() + "channel '" + cname + "' cannot be a parameter");
      }
      t.vars.push_back(v);
    }
  }
  for (const char* k : {"identifier", "robot", "core-parameters"})
    if (!t.head.count(k)) throw Fail(path + ": missing @" + std::string(k));
  if (t.head.count("joint-limits")) {
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
      return t;
    }
    if (f.size() != 2)
      throw Fail(path + ": @joint-limits needs 'core' or two parameter names with {i} (lower, upper)");
    for (int k = 0; k < nd; ++k)
      for (int w = 0; w < 2; ++w) {
        std::string name = replace_all(f[w], "{i}", std::to_string(k + 1));
        int idx = pkm_param_index(model, name.c_str());
        if (idx < 0) throw Fail(path + ": @joint-limits: the core has no parameter '" + name + "'");
        (w ? t.qmax : t.qmin).push_back(idx);
      }
  }
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

// 128-bit FNV-1a of the description text, written as a GUID: the same table and core
// give the same GUID, any change gives another.
std::string guid_of(const std::string& text) {
  uint64_t h1 = 14695981039346656037ull, h2 = 0x6c62272e07bb0142ull;
  for (unsigned char c : text) {
    h1 = (h1 ^ c) * 1099511628211ull;
    h2 = (h2 ^ c) * 0x100000001b3ull + 0x9e3779b97f4a7c15ull;
  }
  char b[64];
  std::snprintf(b, sizeof b, "{%08x-%04x-%04x-%04x-%012llx}", (unsigned)(h1 >> 32), (unsigned)((h1 >> 16) & 0xffff),
                (unsigned)(h1 & 0xffff), (unsigned)(h2 >> 48), (unsigned long long)(h2 & 0xffffffffffffull));
  return b;
}

// The <SourceFiles> list of a source-code FMU (FMI 2.0: inside <ModelExchange> and <CoSimulation>),
// or nothing for a binary FMU.  Not part of the GUID: a source FMU and the binary FMU of
// the same table are the same model.
std::string source_files(const std::vector<std::string>& files) {
  if (files.empty()) return "/>\n";
  std::string o = ">\n    <SourceFiles>\n";
  for (const auto& f : files) o += "      <File name=\"" + xml(f) + "\"/>\n";
  return o + "    </SourceFiles>\n";
}

// <UnitDefinitions> of the units used, <LogCategories> and <DefaultExperiment>: the same
// in the FMI 2.0 and the FMI 3.0 description.
std::string units_and_log_categories(const std::set<std::string>& units) {
  std::ostringstream o;
  if (!units.empty()) {
    o << "  <UnitDefinitions>\n";
    for (const auto& u : units) {
      std::map<std::string, int> e;
      o << "    <Unit name=\"" << xml(u) << "\"";
      if (base_unit(u, e)) {
        o << "><BaseUnit";
        for (const auto& kv : e)
          if (kv.second != 0) o << " " << kv.first << "=\"" << kv.second << "\"";
        o << "/></Unit>\n";
      } else {
        o << "/>\n";
      }
    }
    o << "  </UnitDefinitions>\n";
  }
  o << "  <LogCategories>\n"
       "    <Category name=\"logEvents\" description=\"instantiation, initialization, events\"/>\n"
       "    <Category name=\"logStatusWarning\" description=\"warnings\"/>\n"
       "    <Category name=\"logStatusDiscard\" description=\"a step stopped at a singularity or stroke limit\"/>\n"
       "    <Category name=\"logStatusError\" description=\"errors (bad parameter, bad input, CVODE failure)\"/>\n"
       "    <Category name=\"logStatusFatal\" description=\"fatal errors\"/>\n"
       "    <Category name=\"logFmiCalls\" description=\"every FMI call\"/>\n"
       "  </LogCategories>\n";
  o << "  <DefaultExperiment startTime=\"0\" stopTime=\"1\" stepSize=\"0.001\"/>\n";
  return o.str();
}

std::string model_description(const Table& t, int nd, const std::string& guid,
                              const std::vector<std::string>& sources = {}) {
  const std::string id = t.head.at("identifier");
  std::ostringstream o;
  std::string desc = t.head.count("description") ? t.head.at("description") : id;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << "<!-- Generated by fmu_gen from the model folder's variables.txt and the core's parameter table. -->\n"
    << "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"" << xml(id) << "\" guid=\"" << guid
    << "\"\n  description=\"" << xml(desc) << "\"\n  generationTool=\"pkm fmu_gen\" version=\"" << PKM_FMU_VERSION
    << "\" variableNamingConvention=\"structured\" numberOfEventIndicators=\""
    << t.nindicators() << "\">\n";
  const char* common =
      " canGetAndSetFMUstate=\"true\" canSerializeFMUstate=\"true\" providesDirectionalDerivative=\"false\""
      " canNotUseMemoryManagementFunctions=\"true\" canBeInstantiatedOnlyOncePerProcess=\"false\""
      " needsExecutionTool=\"false\"";
  const std::string files = source_files(sources);
  if (!t.controller())
    o << "  <ModelExchange modelIdentifier=\"" << xml(id) << "\"" << common
      << " completedIntegratorStepNotNeeded=\"false\"" << files << (sources.empty() ? "" : "  </ModelExchange>\n");
  o << "  <CoSimulation modelIdentifier=\"" << xml(id) << "\"" << common
    << " canHandleVariableCommunicationStepSize=\"true\" canInterpolateInputs=\"false\""
       " maxOutputDerivativeOrder=\"0\" canRunAsynchronuously=\"false\""
    << files << (sources.empty() ? "" : "  </CoSimulation>\n");

  std::set<std::string> units;
  for (const auto& v : t.vars)
    if (!no_unit(v.unit)) units.insert(v.unit);
  o << units_and_log_categories(units);
  o << "  <ModelVariables>\n";
  std::map<std::pair<std::string, int>, size_t> pos;  // (channel, index) -> 1-based index
  for (size_t k = 0; k < t.vars.size(); ++k) pos[{t.vars[k].channel, t.vars[k].index}] = k + 1;
  for (size_t k = 0; k < t.vars.size(); ++k) {
    const Var& v = t.vars[k];
    std::string variability = v.causality == "parameter" ? "fixed" : (v.integer ? "discrete" : "continuous");
    o << "    <!-- " << k + 1 << " -->\n    <ScalarVariable name=\"" << xml(v.name) << "\" valueReference=\"" << k + 1
      << "\" description=\"" << xml(v.description) << "\" causality=\"" << v.causality << "\" variability=\""
      << variability << "\"";
    if (v.causality == "parameter") o << " initial=\"exact\"";
    if (v.causality == "output") o << " initial=\"calculated\"";
    o << ">\n      <" << (v.integer ? "Integer" : "Real");
    if (!v.integer && !no_unit(v.unit)) o << " unit=\"" << xml(v.unit) << "\"";
    if (v.channel == "twist") o << " derivative=\"" << pos.at({"pose", v.index}) << "\"";
    if (v.channel == "accel") o << " derivative=\"" << pos.at({"twist", v.index}) << "\"";
    if (v.has_start) o << " start=\"" << (v.integer ? std::to_string((long long)v.start) : num(v.start)) << "\"";
    o << "/>\n    </ScalarVariable>\n";
  }
  o << "  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n";
  std::vector<size_t> outs;
  for (size_t k = 0; k < t.vars.size(); ++k)
    if (t.vars[k].causality == "output") outs.push_back(k + 1);
  for (size_t k : outs) o << "      <Unknown index=\"" << k << "\"/>\n";
  // The state vector is (pose, twist): its derivatives are (twist, accel) in that order.
  o << "    </Outputs>\n";
  if (!t.controller()) {
    o << "    <Derivatives>\n";
    for (const char* ch : {"twist", "accel"})
      for (int k = 0; k < nd; ++k) o << "      <Unknown index=\"" << pos.at({ch, k}) << "\"/>\n";
    o << "    </Derivatives>\n";
  }
  // Every output is calculated (states from x0/xd0, derivatives included).
  o << "    <InitialUnknowns>\n";
  for (size_t k : outs) o << "      <Unknown index=\"" << k << "\"/>\n";
  o << "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n";
  return o.str();
}

// ------------------------------------------------------------------ FMI 3.0

// One FMI 3.0 variable: consecutive rows of the table taken together (an array over the
// joints, the pose coordinates, a gain matrix; or one scalar), or time, or the event
// indicators.  Value references are positions in this list (time is 0).
struct Var3 {
  std::string name, causality, description, unit, kind = "FMU3_ROWS";
  bool integer = false;
  size_t row = 0, count = 1;  // first row of the FMI 2.0 table (0-based) and the rows
  std::vector<int> dims;      // empty: a scalar
};

// The pose channels are arrays over the platform coordinates however the table writes
// them (one row per coordinate or a {p} family): what each array is.
const std::map<std::string, std::string>& pose_arrays() {
  static const std::map<std::string, std::string> m = {
      {"pose", "platform pose (continuous state)"},
      {"twist", "rate of the platform pose, der(pose) (continuous state)"},
      {"accel", "second derivative of the platform pose, der(twist)"},
      {"pose0", "initial platform pose (default: the home pose)"},
      {"twist0", "initial rate of the platform pose"}};
  return m;
}

std::vector<Var3> fmi3_variables(const Table& t, pkm_model* model, int nd, const std::string& path) {
  std::vector<Var3> out;
  Var3 time;
  time.name = "time";
  time.causality = "independent";
  time.description = "simulation time";
  time.unit = "s";
  time.kind = "FMU3_TIME";
  out.push_back(time);
  for (size_t k = 0; k < t.vars.size();) {
    const Var& v = t.vars[k];
    Var3 a;
    a.causality = v.causality;
    a.integer = v.integer;
    a.row = k;
    size_t end = k + 1;
    if (pose_arrays().count(v.channel)) {
      while (end < t.vars.size() && t.vars[end].channel == v.channel) ++end;
      for (size_t j = k; j < end; ++j)
        if (t.vars[j].index != (int)(j - k))
          throw Fail(path + ": the rows of channel " + v.channel + " must give the coordinates in order (FMI 3.0 array)");
      if ((int)(end - k) != nd) throw Fail(path + ": channel " + v.channel + " needs one row per coordinate, together");
      a.name = v.channel;
      a.dims = {nd};
      a.description = pose_arrays().at(v.channel) + ":";
      for (int j = 0; j < nd; ++j)
        a.description += std::string(j ? ", " : " ") + pkm_model_pose_name(model, j) +
                         (no_unit(t.vars[k + j].unit) ? "" : " [" + t.vars[k + j].unit + "]");
    } else if (!v.dims.empty()) {
      while (end < t.vars.size() && t.vars[end].line == v.line) ++end;
      a.name = v.family_name;
      a.dims = v.dims;
      a.description = v.family_description;
      for (const char* p : {"{i}", "{j}", "{r}", "{c}"}) a.description = replace_all(a.description, p, std::string(1, p[1]));
      a.description = replace_all(a.description, "{qu}", pkm_model_joint_unit(model));
      a.description = replace_all(a.description, "{eu}", pkm_model_effort_unit(model));
    } else {
      a.name = v.name;
      a.description = v.description;
    }
    a.count = end - k;
    a.unit = v.unit;
    for (size_t j = k; j < end; ++j)
      if (t.vars[j].unit != v.unit) a.unit.clear();  // mixed units (m and rad): said in the description
    out.push_back(a);
    k = end;
  }
  if (t.nindicators() > 0) {
    Var3 z;
    z.name = "eventIndicators";
    z.causality = "local";
    z.kind = "FMU3_INDICATORS";
    z.count = (size_t)t.nindicators();
    z.dims = {t.nindicators()};
    z.description = "Model Exchange event indicators, each > 0 inside the usable workspace: "
                    "singularity.direct - solver.singMin";
    if (!t.qmin.empty()) z.description += ", then per joint i q[i] - qmin[i], qmax[i] - q[i]";
    out.push_back(z);
  }
  return out;
}

std::string model_description3(const Table& t, const std::vector<Var3>& vars, const std::string& token) {
  const std::string id = t.head.at("identifier");
  std::ostringstream o;
  std::string desc = t.head.count("description") ? t.head.at("description") : id;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << "<!-- Generated by fmu_gen from the model folder's variables.txt and the core's parameter table. -->\n"
    << "<fmiModelDescription fmiVersion=\"3.0\" modelName=\"" << xml(id) << "\" instantiationToken=\"" << token
    << "\"\n  description=\"" << xml(desc) << "\"\n  generationTool=\"pkm fmu_gen\" version=\"" << PKM_FMU_VERSION
    << "\" variableNamingConvention=\"structured\">\n";
  const char* common =
      " canGetAndSetFMUState=\"true\" canSerializeFMUState=\"true\" providesDirectionalDerivatives=\"false\""
      " canBeInstantiatedOnlyOncePerProcess=\"false\" needsExecutionTool=\"false\"";
  if (!t.controller())
    o << "  <ModelExchange modelIdentifier=\"" << xml(id) << "\"" << common
      << " needsCompletedIntegratorStep=\"true\"/>\n";
  o << "  <CoSimulation modelIdentifier=\"" << xml(id) << "\"" << common
    << " canHandleVariableCommunicationStepSize=\"true\" maxOutputDerivativeOrder=\"0\" hasEventMode=\"false\""
       " providesIntermediateUpdate=\"false\" mightReturnEarlyFromDoStep=\""
    << (t.controller() ? "false" : "true") << "\"/>\n";
  std::set<std::string> units;
  for (const auto& v : vars)
    if (!no_unit(v.unit)) units.insert(v.unit);
  o << units_and_log_categories(units);
  o << "  <ModelVariables>\n";
  std::map<std::string, size_t> vr_of;
  for (size_t k = 0; k < vars.size(); ++k) vr_of[vars[k].name] = k;
  for (size_t k = 0; k < vars.size(); ++k) {
    const Var3& v = vars[k];
    const char* type = v.integer ? "Int32" : "Float64";
    std::string variability = v.causality == "parameter" ? "fixed" : (v.integer ? "discrete" : "continuous");
    o << "    <" << type << " name=\"" << xml(v.name) << "\" valueReference=\"" << k << "\" description=\""
      << xml(v.description) << "\" causality=\"" << v.causality << "\" variability=\"" << variability << "\"";
    if (v.causality == "parameter") o << " initial=\"exact\"";
    if (v.causality == "output") o << " initial=\"calculated\"";
    if (!v.integer && !no_unit(v.unit)) o << " unit=\"" << xml(v.unit) << "\"";
    if (v.name == "twist" && vr_of.count("pose")) o << " derivative=\"" << vr_of.at("pose") << "\"";
    if (v.name == "accel" && vr_of.count("twist")) o << " derivative=\"" << vr_of.at("twist") << "\"";
    if (v.kind == "FMU3_ROWS" && (v.causality == "parameter" || v.causality == "input")) {
      o << " start=\"";
      for (size_t j = 0; j < v.count; ++j) {
        const Var& r = t.vars[v.row + j];
        o << (j ? " " : "") << (v.integer ? std::to_string((long long)r.start) : num(r.start));
      }
      o << "\"";
    }
    if (v.dims.empty()) {
      o << "/>\n";
    } else {
      o << ">\n";
      for (int d : v.dims) o << "      <Dimension start=\"" << d << "\"/>\n";
      o << "    </" << type << ">\n";
    }
  }
  o << "  </ModelVariables>\n  <ModelStructure>\n";
  for (size_t k = 0; k < vars.size(); ++k)
    if (vars[k].causality == "output") o << "    <Output valueReference=\"" << k << "\"/>\n";
  // The state vector is (pose, twist): its derivatives are (twist, accel) in that order.
  if (!t.controller())
    for (const char* d : {"twist", "accel"})
      o << "    <ContinuousStateDerivative valueReference=\"" << vr_of.at(d) << "\"/>\n";
  // Every output is calculated (states from pose0/twist0, derivatives included).
  for (size_t k = 0; k < vars.size(); ++k)
    if (vars[k].causality == "output") o << "    <InitialUnknown valueReference=\"" << k << "\"/>\n";
  for (size_t k = 0; k < vars.size(); ++k)
    if (vars[k].kind == "FMU3_INDICATORS") o << "    <EventIndicator valueReference=\"" << k << "\"/>\n";
  o << "  </ModelStructure>\n</fmiModelDescription>\n";
  return o.str();
}

std::string vars3_header(const std::vector<Var3>& vars, const std::string& token, const std::string& src) {
  std::ostringstream o;
  o << "/* Generated by fmu_gen from " << src << " and the core's parameter table: do not edit.\n"
    << " * The FMI 3.0 variables of the FMU (its modelDescription.xml comes from the same run),\n"
    << " * each over rows of FMU_MODEL.vars (fmu_vars.h). */\n"
    << "#ifndef PKM_FMU_VARS3_H\n#define PKM_FMU_VARS3_H\n\n#include \"fmu_model.h\"\n\n"
    << "#define FMU3_TOKEN " << cstr(token) << "\n#define FMU3_NVARS " << vars.size() << "\n\n"
    << "static const fmu3_var FMU3_VARS[FMU3_NVARS] = {\n";
  for (size_t k = 0; k < vars.size(); ++k) {
    const Var3& v = vars[k];
    o << "    {" << k << "u, " << cstr(v.name) << ", " << (v.integer ? "FMU_INTEGER" : "FMU_REAL") << ", " << v.kind
      << ", " << v.row << ", " << v.count << "},\n";
  }
  o << "};\n\n#endif\n";
  return o.str();
}

std::string c_ident(const std::string& name) {
  std::string o;
  for (char c : name) {
    bool ok = std::isalnum((unsigned char)c);
    if (ok) o += c;
    else if (o.empty() || o.back() != '_') o += '_';
  }
  while (!o.empty() && o.back() == '_') o.pop_back();
  return o;
}

std::string vars_header(const Table& t, int nd, int np, const std::string& guid, const std::string& src) {
  std::ostringstream o;
  o << "/* Generated by fmu_gen from " << src << " and the core's parameter table: do not edit.\n"
    << " * The value references here and modelDescription.xml come from the same run. */\n"
    << "#ifndef PKM_FMU_VARS_H\n#define PKM_FMU_VARS_H\n\n#include \"fmu_model.h\"\n\n"
    << "#define FMU_IDENTIFIER " << cstr(t.head.at("identifier")) << "\n"
    << "#define FMU_GUID " << cstr(guid) << "\n"
    << "#define FMU_ROBOT " << cstr(t.robot_name) << "\n"
    << "/* The robot's description (docs/robots.md), compiled by the core when the FMU is\n"
    << " * instantiated; NULL for the robots written in C++. */\n"
    << "#define FMU_DESCRIPTION " << (t.description.empty() ? "NULL" : cstr(t.description)) << "\n"
    << "#define FMU_PARAM_SET " << cstr(t.head.count("paramset") ? t.head.at("paramset") : "default") << "\n"
    << "#define FMU_NDOF " << nd << "\n#define FMU_NPARAM " << np << "\n#define FMU_NVARS " << t.vars.size()
    << "\n#define FMU_LTI_STATES " << t.nx
    << "\n\n/* Value references by name ([i] and '.' become '_'). */\nenum fmu_vr {\n";
  std::set<std::string> ids;
  for (size_t k = 0; k < t.vars.size(); ++k) {
    std::string id = "FMU_VR_" + c_ident(t.vars[k].name);
    if (!ids.insert(id).second) throw Fail("C name " + id + " of " + t.vars[k].name + " is not unique");
    o << "  " << id << " = " << k + 1 << ",\n";
  }
  o << "};\n\nstatic const fmu_var FMU_VARS[FMU_NVARS] = {\n";
  for (size_t k = 0; k < t.vars.size(); ++k) {
    const Var& v = t.vars[k];
    const char* caus = v.causality == "parameter" ? "FMU_PARAMETER" : v.causality == "input" ? "FMU_INPUT" : "FMU_OUTPUT";
    o << "    {" << k + 1 << "u, " << cstr(v.name) << ", " << (v.integer ? "FMU_INTEGER" : "FMU_REAL") << ", " << caus
      << ", " << channels().at(v.channel).first << ", " << v.index << ", " << num(v.start) << "},\n";
  }
  o << "};\n\n";
  // Joint limits for the Model Exchange event indicators (core parameter numbers).
  if (t.qmin.empty()) {
    o << "#define FMU_QMIN_PARAM NULL\n#define FMU_QMAX_PARAM NULL\n";
  } else {
    for (int w = 0; w < 2; ++w) {
      o << "static const int FMU_" << (w ? "QMAX" : "QMIN") << "[FMU_NDOF] = {";
      for (int k = 0; k < nd; ++k) o << (k ? ", " : "") << (w ? t.qmax : t.qmin)[k];
      o << "};\n";
    }
    o << "#define FMU_QMIN_PARAM FMU_QMIN\n#define FMU_QMAX_PARAM FMU_QMAX\n";
  }
  o << "#define FMU_NINDICATORS " << t.nindicators() << "\n\n#endif\n";
  return o.str();
}

void write_if_changed(const std::string& path, const std::string& text) {
  std::ifstream in(path);
  std::stringstream old;
  old << in.rdbuf();
  if (in && old.str() == text) return;  // keep the timestamp: no needless rebuilds
  std::ofstream out(path);
  out << text;
  if (!out) throw Fail(path + ": cannot write");
}

}  // namespace

int main(int argc, char** argv) {
  // --fmi3 <modelDescription.xml> <fmu_vars3.h>: the FMI 3.0 description and table too.
  std::string md3, vars3;
  if (argc > 3 && std::string(argv[1]) == "--fmi3") {
    md3 = argv[2];
    vars3 = argv[3];
    argv += 3;
    argc -= 3;
  }
  if (argc < 4 || argc == 5) {
    std::cerr << "usage: fmu_gen [--fmi3 <modelDescription.xml> <fmu_vars3.h>] <variables.txt>"
                 " <modelDescription.xml> <fmu_vars.h> [<source modelDescription.xml> <source file>...]\n";
    return 2;
  }
  pkm_model* model = nullptr;
  try {
    Table t = read_table(argv[1], model);
    int nd = pkm_model_ndof(model), np = pkm_model_nparam(model);
    check(t, nd, argv[1]);
    std::string guid = guid_of(model_description(t, nd, "{}"));
    write_if_changed(argv[2], model_description(t, nd, guid));
    write_if_changed(argv[3], vars_header(t, nd, np, guid, argv[1]));
    // The FMI 3.0 variables always (the binary's FMI 3.0 functions need their table).
    const std::vector<Var3> v3 = fmi3_variables(t, model, nd, argv[1]);
    const std::string token = guid_of(model_description3(t, v3, "{}"));
    if (!md3.empty()) write_if_changed(md3, model_description3(t, v3, token));
    if (!vars3.empty()) write_if_changed(vars3, vars3_header(v3, token, argv[1]));
    if (argc > 5)  // the source-code FMU's description: the same model, its sources listed
      write_if_changed(argv[4], model_description(t, nd, guid, std::vector<std::string>(argv + 5, argv + argc)));
  } catch (const std::exception& e) {
    std::cerr << "fmu_gen: " << e.what() << "\n";
    pkm_model_destroy(model);
    return 1;
  }
  pkm_model_destroy(model);
  return 0;
}
