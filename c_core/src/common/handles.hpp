// The structs behind the opaque C handles pkm_model and pkm_data.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "common/course.hpp"
#include "common/robot.hpp"

namespace pkm {
namespace drive {
struct Params;
}
}  // namespace pkm

struct pkm_model {
  const pkm::Robot* robot = nullptr;
  std::string robot_name;
  std::vector<pkm::ParamSpec> specs;
  std::vector<double> values;
  // Per actuated joint i, the indices of the parameters holding its lower and upper limit
  // ([2 i], [2 i + 1]; -1: none), looked up once from the robot's joint_limit_param: the
  // forward kinematics check every call's joints against them.
  std::vector<int> joint_limit_index;
  // Null until pkm_model_validate succeeds; reset by pkm_param_set.
  std::shared_ptr<const pkm::RobotModel> compiled;
  std::shared_ptr<const pkm::drive::Params> drive;  // the drive layer's parameters (dynamics/drive.hpp)
  std::vector<pkm::Course> courses;  // the parameters' time courses (pkm_param_set_course), one per parameter at most
};

struct pkm_data {
  const pkm::Robot* robot = nullptr;
  int ndof = 0;
  std::unique_ptr<pkm::RobotData> rd;
  const pkm::RobotModel* rd_for = nullptr;  // the compiled model rd was made for
  std::shared_ptr<const pkm::RobotModel> keep;  // keeps rd_for alive
  std::string error;
};

namespace pkm {
// The compiled model and the work data of (m, d), rebuilding the work data if the model
// was recompiled since; throws Error if the pair does not belong together or m is not
// validated.
const RobotModel& prepare(const pkm_model* m, pkm_data* d);
}  // namespace pkm
