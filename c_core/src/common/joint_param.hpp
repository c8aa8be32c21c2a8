// The name of a per-joint parameter of the drive layer: "<prefix>[i].<key>" ("rail[2].offset"),
// the one spelling the drive, the generic joint force and the joint limits share.
#pragma once

#include <string>

#include "common/robot.hpp"

namespace pkm {

// `key` of actuated joint i (0-based) of robot r.
inline std::string joint_param(const Robot& r, int i, const char* key) {
  return std::string(r.joint_prefix()) + "[" + std::to_string(i + 1) + "]." + key;
}

}  // namespace pkm
