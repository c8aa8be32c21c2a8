// Robots compiled from description files, through the C API: the 6-PUS the core serves from
// robots/6pus.toml against the hand-written 6-PUS kept as a test oracle ("6pus_hand",
// c_core/tests/oracles/), a description registered from text (what an FMU does),
// its errors with file and line, and forward kinematics of an arm robot.
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.hpp"

using namespace pkm_test;

namespace {

// The small linear Delta the tests of described robots share (its file names it tiny_delta).
std::string tiny_delta() {
  std::ifstream f(PKM_TEST_DIR "/robots/tiny_delta.toml");
  std::stringstream s;
  s << f.rdbuf();
  EXPECT_FALSE(s.str().empty()) << PKM_TEST_DIR "/robots/tiny_delta.toml";
  return s.str();
}

}  // namespace

TEST(Described, SixPusDescriptionEqualsTheHandWrittenModel) {
  auto a = make_model("6pus_hand"), b = make_model("6pus");
  ASSERT_TRUE(a && b);
  auto da = make_data(a.get()), db = make_data(b.get());
  ASSERT_EQ(pkm_model_nparam(a.get()), pkm_model_nparam(b.get()));
  for (int i = 0; i < pkm_model_nparam(a.get()); ++i) {
    EXPECT_STREQ(pkm_param_name(a.get(), i), pkm_param_name(b.get(), i));
    EXPECT_EQ(pkm_param_get(a.get(), i), pkm_param_get(b.get(), i)) << pkm_param_name(a.get(), i);
  }
  std::mt19937_64 rng(4);
  double home[6];
  pkm_model_home(a.get(), home);
  for (int k = 0; k < 200; ++k) {
    double x[6], xd[6], xdd[6], qa[6], qb[6], ta[6], tb[6], fa[6], fb[6];
    for (int j = 0; j < 6; ++j) {
      x[j] = home[j] + uniform(rng, -1, 1) * (j < 3 ? 0.01 : 0.05);
      xd[j] = uniform(rng, -0.05, 0.05);
      xdd[j] = uniform(rng, -1, 1);
    }
    ASSERT_EQ(pkm_ik(a.get(), da.get(), x, qa), PKM_OK);
    ASSERT_EQ(pkm_ik(b.get(), db.get(), x, qb), PKM_OK);
    ASSERT_EQ(pkm_inverse_dynamics(a.get(), da.get(), x, xd, xdd, ta), PKM_OK);
    ASSERT_EQ(pkm_inverse_dynamics(b.get(), db.get(), x, xd, xdd, tb), PKM_OK);
    ASSERT_EQ(pkm_forward_dynamics(a.get(), da.get(), x, xd, ta, fa), PKM_OK);
    ASSERT_EQ(pkm_forward_dynamics(b.get(), db.get(), x, xd, ta, fb), PKM_OK);
    for (int j = 0; j < 6; ++j) {
      EXPECT_NEAR(qa[j], qb[j], 1e-14);
      EXPECT_NEAR(ta[j], tb[j], 1e-12);
      EXPECT_NEAR(fa[j], fb[j], 1e-10);
    }
  }
}

TEST(Described, RegisteredFromTextAnswersToItsNameAndFkInvertsIk) {
  char err[512] = "";
  ASSERT_EQ(pkm_robot_register_description(tiny_delta().c_str(), "tiny.toml", err, sizeof err), PKM_OK) << err;
  auto m = make_model("tiny_delta");
  ASSERT_TRUE(m);
  EXPECT_EQ(pkm_model_ndof(m.get()), 3);
  EXPECT_STREQ(pkm_model_pose_name(m.get(), 2), "z");
  EXPECT_STREQ(pkm_model_joint_prefix(m.get()), "rail");
  auto d = make_data(m.get());
  const double x[3] = {0.02, -0.01, 0.25};
  double q[3], xr[3];
  ASSERT_EQ(pkm_ik(m.get(), d.get(), x, q), PKM_OK);
  double home[3];
  pkm_model_home(m.get(), home);
  ASSERT_EQ(pkm_fk(m.get(), d.get(), q, home, nullptr, xr, nullptr), PKM_OK);
  for (int j = 0; j < 3; ++j) EXPECT_NEAR(xr[j], x[j], 1e-12);
}

TEST(Described, ErrorsNameTheFileAndLine) {
  char err[512] = "";
  std::string bad = tiny_delta();
  bad.replace(bad.find("rod_length = 0.2"), 16, "rod_length = -0.2");
  EXPECT_EQ(pkm_robot_register_description(bad.c_str(), "bad.toml", err, sizeof err), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::strstr(err, "bad.toml:18:"), nullptr) << err;  // two header comment lines
  EXPECT_NE(std::strstr(err, "rod_length"), nullptr) << err;
  pkm_model* m = pkm_model_create("no/such/file.toml", nullptr, err, sizeof err);
  EXPECT_EQ(m, nullptr);
  EXPECT_NE(std::strstr(err, "cannot read robot description no/such/file.toml"), nullptr) << err;
  EXPECT_EQ(pkm_robot_register_description(nullptr, "x", err, sizeof err), PKM_ERR_ARGUMENT);
}
