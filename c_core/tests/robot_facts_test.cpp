// The robot facts of pkm.h: every robot lists its parameter sets, pose coordinates and
// joint units, and its joint limits point at real parameters; model creation reports a
// status.  (What the Python package, the FMUs and the integrator read instead of
// restating them.)
#include <set>
#include <string>

#include "test_support.hpp"

using namespace pkm_test;

TEST(RobotFacts, EveryRobotDescribesItself) {
  const int n = pkm_robot_count();
  ASSERT_GE(n, 3);
  std::set<std::string> names;
  for (int i = 0; i < n; ++i) names.insert(pkm_robot_name(i));
  EXPECT_TRUE(names.count("6pus") && names.count("quattro") && names.count("fourbar"));
  EXPECT_STREQ(pkm_robot_name(n), "");
  for (const std::string& r : names) {
    const int ns = pkm_robot_param_set_count(r.c_str());
    ASSERT_GE(ns, 1) << r;
    EXPECT_STREQ(pkm_robot_param_set_name(r.c_str(), 0), "default") << r;
    for (int k = 0; k < ns; ++k) {
      auto m = make_model(r.c_str(), pkm_robot_param_set_name(r.c_str(), k));  // every listed set opens
      ASSERT_NE(m, nullptr);
      const int nd = pkm_model_ndof(m.get());
      for (int i = 0; i < nd; ++i) {
        const std::string unit = pkm_model_pose_unit(m.get(), i);
        EXPECT_TRUE(unit == "m" || unit == "rad") << r << " pose " << i << ": " << unit;
        EXPECT_STRNE(pkm_model_pose_name(m.get(), i), "") << r << " pose " << i;
        int lo = -2, hi = -2;
        ASSERT_EQ(pkm_model_joint_limits(m.get(), i, &lo, &hi), PKM_OK);
        for (int idx : {lo, hi})
          if (idx >= 0) EXPECT_EQ(std::string(pkm_param_unit(m.get(), idx)), pkm_model_joint_unit(m.get())) << r;
      }
      EXPECT_STREQ(pkm_model_pose_name(m.get(), nd), "");
      EXPECT_EQ(pkm_model_joint_limits(m.get(), nd, nullptr, nullptr), PKM_ERR_ARGUMENT);
    }
  }
  EXPECT_EQ(pkm_robot_param_set_count("nonesuch"), -1);
}

TEST(RobotFacts, TheKnownRobotsFactsAreTheirs) {
  auto six = make_model("6pus"), quattro = make_model("quattro"), four = make_model("fourbar");
  EXPECT_STREQ(pkm_model_pose_name(six.get(), 3), "rx");
  EXPECT_STREQ(pkm_model_pose_unit(six.get(), 2), "m");
  EXPECT_STREQ(pkm_model_pose_unit(six.get(), 5), "rad");
  EXPECT_STREQ(pkm_model_joint_unit(six.get()), "m");
  EXPECT_STREQ(pkm_model_effort_unit(six.get()), "N");
  EXPECT_STREQ(pkm_model_joint_prefix(six.get()), "rail");
  EXPECT_STREQ(pkm_model_pose_name(quattro.get(), 3), "rz");
  EXPECT_STREQ(pkm_model_joint_unit(quattro.get()), "rad");
  EXPECT_STREQ(pkm_model_effort_unit(quattro.get()), "N m");
  EXPECT_EQ(pkm_robot_param_set_count("quattro"), 2);
  EXPECT_STREQ(pkm_robot_param_set_name("quattro", 1), "appendix_a");
  // the four-bar's pose is its crank angle
  EXPECT_STREQ(pkm_model_pose_name(four.get(), 0), "theta");
  EXPECT_STREQ(pkm_model_pose_unit(four.get(), 0), "rad");
  // a tracker measures the pose, except on the four-bar: its coupler's mid point X [m]
  ASSERT_EQ(pkm_model_tracker_count(six.get()), 6);
  EXPECT_STREQ(pkm_model_tracker_name(six.get(), 3), "rx");
  EXPECT_STREQ(pkm_model_tracker_unit(quattro.get(), 3), "rad");
  ASSERT_EQ(pkm_model_tracker_count(four.get()), 1);
  EXPECT_STREQ(pkm_model_tracker_name(four.get(), 0), "X");
  EXPECT_STREQ(pkm_model_tracker_unit(four.get(), 0), "m");
  EXPECT_STREQ(pkm_model_tracker_name(four.get(), 1), "");
  EXPECT_EQ(pkm_model_tracker_count(nullptr), -1);
  // the parameters of a geometric error: the rod length of each leg on the 6-PUS and the
  // Quattro, none named on the four-bar
  EXPECT_STREQ(pkm_model_geometry_param(six.get(), 0), "leg[1].L");
  EXPECT_STREQ(pkm_model_geometry_param(six.get(), 5), "leg[6].L");
  EXPECT_STREQ(pkm_model_geometry_param(six.get(), 6), "");
  EXPECT_STREQ(pkm_model_geometry_param(quattro.get(), 0), "leg[1].L");
  EXPECT_STREQ(pkm_model_geometry_param(quattro.get(), 3), "leg[4].L");
  EXPECT_STREQ(pkm_model_geometry_param(quattro.get(), 4), "");
  EXPECT_STREQ(pkm_model_geometry_param(four.get(), 0), "");
  EXPECT_STREQ(pkm_model_geometry_param(six.get(), -1), "");
  EXPECT_STREQ(pkm_model_geometry_param(nullptr, 0), "");
  int lo, hi;
  ASSERT_EQ(pkm_model_joint_limits(six.get(), 2, &lo, &hi), PKM_OK);
  EXPECT_STREQ(pkm_param_name(six.get(), lo), "rail[3].qmin");
  EXPECT_STREQ(pkm_param_name(six.get(), hi), "rail[3].qmax");
  ASSERT_EQ(pkm_model_joint_limits(four.get(), 0, &lo, &hi), PKM_OK);
  EXPECT_EQ(lo, -1);
  EXPECT_EQ(hi, -1);
}

TEST(RobotFacts, ModelCreationReportsAStatus) {
  char err[512] = "";
  pkm_model* m = reinterpret_cast<pkm_model*>(0x1);
  EXPECT_EQ(pkm_model_create_status("hexapod9", nullptr, &m, err, sizeof err), PKM_ERR_ARGUMENT);
  EXPECT_EQ(m, nullptr);
  EXPECT_NE(std::string(err).find("known: fourbar, "), std::string::npos) << err;
  EXPECT_NE(std::string(err).find(" 6pus, "), std::string::npos) << err;
  EXPECT_NE(std::string(err).find(" quattro, "), std::string::npos) << err;
  EXPECT_EQ(pkm_model_create_status("quattro", "appendix_b", &m, err, sizeof err), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(err).find("appendix_a"), std::string::npos) << err;
  ASSERT_EQ(pkm_model_create_status("quattro", "appendix_a", &m, err, sizeof err), PKM_OK) << err;
  pkm_model_destroy(m);
}
