// PLACEHOLDER robot '6pus': to be replaced by its full implementation.
#include "common/robot.hpp"

namespace pkm {
namespace {
struct Placeholder final : Robot {
  const char* name() const override { return "6pus"; }
  int ndof() const override { return 6; }
  std::vector<ParamSpec> param_specs(const std::string&) const override { return {}; }
  std::unique_ptr<RobotModel> compile(const std::vector<ParamSpec>&, const std::vector<double>&) const override {
    return std::make_unique<RobotModel>();
  }
  void home(const RobotModel&, double* x) const override {
    for (int i = 0; i < 6; ++i) x[i] = 0;
  }
};
}  // namespace
const Robot* robot_6pus() {
  static Placeholder r;
  return &r;
}
}  // namespace pkm
