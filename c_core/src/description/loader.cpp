// Finding, reading and caching robot descriptions (described_robot.hpp: load_described,
// register_description, bundled_descriptions): the search path, the checks a description
// passes once its robot exists (parameter names and ranges of [defaults] and [sets.*], every
// set compiling at home, names not taken), one robot per file text for the process.
#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <unordered_map>

#include "description/axis_robot.hpp"
#include "description/described_robot.hpp"
#include "description/schema.hpp"
#include "description/serial_chain.hpp"
#include "dynamics/drive.hpp"

namespace pkm {
namespace described {

namespace {

std::string read_file(const std::string& path, bool& ok) {
  std::ifstream f(path, std::ios::binary);
  ok = bool(f);
  if (!ok) return "";
  std::ostringstream os;
  os << f.rdbuf();
  return os.str();
}

std::vector<std::string> search_dirs() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("PKM_ROBOT_PATH")) {
    std::string s(env), cur;
    for (char c : s + ":") {
      if (c == ':') {
        if (!cur.empty()) dirs.push_back(cur);
        cur.clear();
      } else {
        cur += c;
      }
    }
  }
#ifdef PKM_ROBOTS_DIR
  dirs.push_back(PKM_ROBOTS_DIR);
#endif
  return dirs;
}

bool is_path(const std::string& s) {
  return s.find('/') != std::string::npos ||
         (s.size() > 5 && s.compare(s.size() - 5, 5, ".toml") == 0);
}

// Robots made so far, by file text (a changed file gives a new robot; old models keep theirs).
std::mutex g_mu;
std::map<std::string, std::unique_ptr<DescribedRobot>>& cache() {
  static std::map<std::string, std::unique_ptr<DescribedRobot>> c;
  return c;
}

const Robot* make(const std::string& path, const std::string& text) {
  std::lock_guard<std::mutex> lock(g_mu);
  auto& c = cache();
  const std::string key = path + '\n' + text;
  auto it = c.find(key);
  if (it != c.end()) return it->second.get();
  static int serial = 0;
  std::vector<ChainJointInfo> chain;
  const toml::Document doc = toml::parse(text, path);
  Description desc = is_serial_description(doc) ? read_serial_description(doc, path, chain) : read_description(doc, path);
  std::unique_ptr<DescribedRobot> r;
  if (desc.structure == Structure::serial) r = std::make_unique<SerialRobot>(std::move(desc), std::move(chain), ++serial);
  else if (desc.structure == Structure::axis) r = std::make_unique<AxisRobot>(std::move(desc), ++serial);
  else r = std::make_unique<DescribedRobot>(std::move(desc), ++serial);
  const Description& d = r->description();
  // Every named value must be a parameter of the robot or of its drive layer, inside the
  // parameter's range (as anywhere a value is set: params=, set_params, the FMUs).
  const auto drive_specs = drive::specs(*r);
  std::unordered_map<std::string, const ParamSpec*> by_name;
  for (const auto& p : d.params) by_name.emplace(p.name, &p);
  for (const auto& p : drive_specs) by_name.emplace(p.name, &p);
  for (const auto& s : d.sets)
    for (const auto& o : s.second) {
      const auto it = by_name.find(o.name);
      const std::string where = path + ":" + std::to_string(o.line) + ": ";
      if (it == by_name.end())
        throw Error(PKM_ERR_ARGUMENT, where + "'" + o.name + "' is not a parameter of " + d.name + " (cosim params " +
                                          path + " lists them)");
      const ParamSpec& p = *it->second;
      if (!(o.value >= p.lo && o.value <= p.hi))
        throw Error(PKM_ERR_ARGUMENT, where + o.name + " = " + num(o.value) + " " + p.unit + " is outside [" +
                                          num(p.lo) + ", " + num(p.hi) + "] (" + p.description + ")");
    }
  // The default set must compile: home reachable, no singularity there.
  for (const auto& s : d.sets) {
    auto specs = r->param_specs(s.first);
    std::vector<double> vals;
    for (const auto& p : specs) vals.push_back(p.value);
    try {
      r->compile(specs, vals);
    } catch (const Error& e) {
      // Name the home line and, for a leg's failure, the [[leg]] table it came from.
      std::string msg = e.what(), where;
      const auto k = msg.find("leg ");
      if (k != std::string::npos) {
        const int leg = std::atoi(msg.c_str() + k + 4);
        if (leg >= 1 && leg <= (int)d.leg_lines.size())
          where = " (leg " + std::to_string(leg) + " is the [[leg]] on line " + std::to_string(d.leg_lines[leg - 1]) + ")";
      }
      throw Error(PKM_ERR_ARGUMENT, path + ":" + std::to_string(d.home_line) + ": parameter set '" + s.first + "': " +
                                        msg + where);
    }
  }
  const Robot* out = r.get();
  c.emplace(key, std::move(r));
  return out;
}

// A file loaded by path answers to its robot.name from then on: a name that already means
// another robot (one written in C++, or a bundled description of the project's robots/)
// would stand for two robots (and sweep workers or FMUs re-created by name get the other).
void refuse_taken_name(const Description& d, const std::string& text) {
  const std::string where = d.file + ":" + std::to_string(d.name_line) + ": robot.name '" + d.name + "' ";
  if (is_builtin_robot(d.name))
    throw Error(PKM_ERR_ARGUMENT, where + "is the name of a robot written in C++: give the description another name");
#ifdef PKM_ROBOTS_DIR
  bool ok = false;
  const std::string bundled = std::string(PKM_ROBOTS_DIR) + "/" + d.name + ".toml";
  const std::string bundled_text = read_file(bundled, ok);
  if (ok && bundled_text != text)
    throw Error(PKM_ERR_ARGUMENT, where + "is taken by the bundled " + bundled + ", a different description: give "
                                  "this one another name");
#endif
}

}  // namespace

const Robot* load_described(const std::string& name) {
  bool ok = false;
  if (is_path(name)) {
    const std::string text = read_file(name, ok);
    if (!ok) throw Error(PKM_ERR_ARGUMENT, "cannot read robot description " + name);
    const Robot* r = make(name, text);
    refuse_taken_name(static_cast<const DescribedRobot&>(*r).description(), text);
    return r;
  }
  for (const auto& dir : search_dirs()) {
    const std::string path = dir + "/" + name + ".toml";
    const std::string text = read_file(path, ok);
    if (ok) return make(path, text);
  }
  // A robot loaded from a path earlier answers to its name too (the newest of that name).
  std::lock_guard<std::mutex> lock(g_mu);
  const DescribedRobot* found = nullptr;
  for (const auto& kv : cache())
    if (kv.second->description().name == name && (!found || kv.second->serial() > found->serial()))
      found = kv.second.get();
  return found;
}

const Robot* register_description(const std::string& text, const std::string& file) { return make(file, text); }

std::vector<std::string> bundled_descriptions() {
  std::vector<std::string> out;
  for (const auto& dir : search_dirs()) {
    // A short listing without <filesystem>'s exceptions: try the index file robots.list.
    bool ok = false;
    const std::string list = read_file(dir + "/robots.list", ok);
    if (!ok) continue;
    std::istringstream is(list);
    std::string line;
    while (std::getline(is, line)) {
      const auto h = line.find('#');
      if (h != std::string::npos) line = line.substr(0, h);
      line.erase(0, line.find_first_not_of(" \t\r"));
      line.erase(line.find_last_not_of(" \t\r") + 1);
      if (!line.empty() && std::find(out.begin(), out.end(), line) == out.end()) out.push_back(line);
    }
  }
  return out;
}

}  // namespace described
}  // namespace pkm
