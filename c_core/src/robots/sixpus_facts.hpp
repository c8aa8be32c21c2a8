// What the 6-PUS offers beyond the common algorithms, on the robot the core serves from its
// description (robots/6pus.toml, description/described_robot.hpp): the per-leg calibration
// rows of Tiberi 2020 ch. 4 (pkm_6pus_calib_rows, the 60-parameter calibration) and the leg
// points (pkm_6pus_leg_points).  Any described robot of six legs over the whole pose
// (x, y, z, rx, ry, rz), each a slider on a rail and a rod (PUS, PSS), is a 6-PUS in this sense.
#pragma once

#include "common/robot.hpp"

namespace pkm {
namespace sixpus {

// The robot is a described 6-PUS: six rail-and-rod legs, the whole pose its coordinates.
bool is_6pus(const Robot& r);

}  // namespace sixpus
}  // namespace pkm
