// PLACEHOLDER robot 'fourbar': to be replaced by its full implementation.
#include "common/robot.hpp"

namespace pkm {
namespace {
struct Placeholder final : Robot {
  const char* name() const override { return "fourbar"; }
  int ndof() const override { return 1; }
  std::vector<ParamSpec> param_specs(const std::string&) const override { return {}; }
  std::unique_ptr<RobotModel> compile(const std::vector<ParamSpec>&, const std::vector<double>&) const override {
    return std::make_unique<RobotModel>();
  }
  void home(const RobotModel&, double* x) const override {
    for (int i = 0; i < 1; ++i) x[i] = 0;
  }
};
}  // namespace
const Robot* robot_fourbar() {
  static Placeholder r;
  return &r;
}
}  // namespace pkm
