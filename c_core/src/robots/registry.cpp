// The robots compiled into the core.  A new robot is one file in robots/ plus a line here.
#include "common/robot.hpp"

namespace pkm {

const Robot* robot_6pus();
const Robot* robot_quattro();
const Robot* robot_fourbar();

static const Robot* all_robots[] = {robot_6pus(), robot_quattro(), robot_fourbar()};

const Robot* find_robot(const std::string& name) {
  for (const Robot* r : all_robots)
    if (r && name == r->name()) return r;
  return nullptr;
}

int robot_count() { return (int)(sizeof all_robots / sizeof all_robots[0]); }
const Robot* robot_at(int i) { return i >= 0 && i < robot_count() ? all_robots[i] : nullptr; }

std::string known_robots() {
  std::string s;
  for (const Robot* r : all_robots) {
    if (!r) continue;
    if (!s.empty()) s += ", ";
    s += r->name();
  }
  return s;
}

}  // namespace pkm
