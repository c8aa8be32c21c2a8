// The robots the core serves: the ones written in C++ (a file in robots/ plus a line here) and
// the descriptions of the search path (robots/robots.list; "6pus" is robots/6pus.toml,
// "quattro" robots/quattro.toml).
#include <vector>

#include "common/robot.hpp"
#include "description/described_robot.hpp"
#include "robots/quattro_facts.hpp"
#include "robots/sixpus_facts.hpp"

namespace pkm {

const Robot* robot_fourbar();

// A test build may add robots without touching this file: it links a definition of these
// two (c_core/tests/robots/, built into libpkm_toy.so).  In libpkm.so they stay undefined.
[[gnu::weak]] int test_robot_count();
[[gnu::weak]] const Robot* test_robot_at(int i);
// The hand-written models kept as test oracles (c_core/tests/oracles/, libpkm_oracle.so).
[[gnu::weak]] int oracle_robot_count();
[[gnu::weak]] const Robot* oracle_robot_at(int i);

namespace {
const std::vector<const Robot*>& all_robots() {
  static const std::vector<const Robot*> robots = [] {
    std::vector<const Robot*> v = {robot_fourbar()};
    if (test_robot_count && test_robot_at)
      for (int i = 0; i < test_robot_count(); ++i) v.push_back(test_robot_at(i));
    if (oracle_robot_count && oracle_robot_at)
      for (int i = 0; i < oracle_robot_count(); ++i) v.push_back(oracle_robot_at(i));
    return v;
  }();
  return robots;
}
// Former names of served robots: the descriptions "6pus" and "quattro" were "6pus_described"
// and "quattro_described" while hand-written robots of those names existed.
const char* alias_of(const std::string& name) {
  if (name == "6pus_described") return "6pus";
  if (name == "quattro_described") return "quattro";
  return nullptr;
}
}  // namespace

// Names of the descriptions in the search path (robots/robots.list), read once.
const std::vector<std::string>& described_names() {
  static const std::vector<std::string> names = described::bundled_descriptions();
  return names;
}

const Robot* find_robot(const std::string& name) {
  for (const Robot* r : all_robots())
    if (r && name == r->name()) return r;
  if (const char* a = alias_of(name)) return find_robot(a);
  return described::load_described(name);  // nullptr if it is no description either
}

int robot_count() { return (int)(all_robots().size() + described_names().size()); }

const Robot* robot_at(int i) {
  const int nb = (int)all_robots().size();
  if (i >= 0 && i < nb) return all_robots()[i];
  if (i < nb || i >= robot_count()) return nullptr;
  try {
    return described::load_described(described_names()[i - nb]);
  } catch (const Error&) {
    return nullptr;  // a bad description is reported where it is used
  }
}

const char* robot_name_at(int i) {
  const int nb = (int)all_robots().size();
  if (i >= 0 && i < nb) return all_robots()[i]->name();
  if (i >= nb && i < robot_count()) return described_names()[i - nb].c_str();
  return "";
}

bool is_builtin_robot(const std::string& name) {
  for (const Robot* r : all_robots())
    if (r && name == r->name()) return true;
  return false;
}

std::vector<const char*> robot_features(const Robot& r) {
  std::vector<const char*> f = r.features();
  if (sixpus::is_6pus(r)) f.insert(f.end(), {"6pus_calib_rows", "6pus_leg_points"});
  if (quattro_facts::is_described_quattro(r)) f.insert(f.end(), {"quattro_indices", "quattro_gimre", "quattro_points"});
  return f;
}

std::string known_robots() {
  std::string s;
  for (int i = 0; i < robot_count(); ++i) s += (s.empty() ? "" : ", ") + std::string(robot_name_at(i));
  return s + " or a path to a description file";
}

}  // namespace pkm
