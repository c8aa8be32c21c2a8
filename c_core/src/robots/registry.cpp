// The robots compiled into the core.  A new robot is one file in robots/ plus a line here.
#include <vector>

#include "common/robot.hpp"

namespace pkm {

const Robot* robot_6pus();
const Robot* robot_quattro();
const Robot* robot_fourbar();

// A test build may add robots without touching this file: it links a definition of these
// two (c_core/tests/robots/, built into libpkm_toy.so).  In libpkm.so they stay undefined.
[[gnu::weak]] int test_robot_count();
[[gnu::weak]] const Robot* test_robot_at(int i);

namespace {
const std::vector<const Robot*>& all_robots() {
  static const std::vector<const Robot*> robots = [] {
    std::vector<const Robot*> v = {robot_6pus(), robot_quattro(), robot_fourbar()};
    if (test_robot_count && test_robot_at)
      for (int i = 0; i < test_robot_count(); ++i) v.push_back(test_robot_at(i));
    return v;
  }();
  return robots;
}
}  // namespace

const Robot* find_robot(const std::string& name) {
  for (const Robot* r : all_robots())
    if (r && name == r->name()) return r;
  return nullptr;
}

int robot_count() { return (int)all_robots().size(); }
const Robot* robot_at(int i) { return i >= 0 && i < robot_count() ? all_robots()[i] : nullptr; }

std::string known_robots() {
  std::string s;
  for (const Robot* r : all_robots()) {
    if (!r) continue;
    if (!s.empty()) s += ", ";
    s += r->name();
  }
  return s;
}

}  // namespace pkm
