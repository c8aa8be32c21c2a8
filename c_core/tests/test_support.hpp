// Scaffolding shared by the GoogleTest files of the C API: a fixture owning one model and
// its data, parameter access by name that fails with the name and the core's message,
// and the small numeric helpers every file needs (degrees, seeded uniform draws, central
// differences).  Not a test itself: CMake only builds c_core/tests/*_test.cpp.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>
#include <memory>
#include <random>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "pkm/pkm.h"

namespace pkm_test {

constexpr double kPi = 3.14159265358979323846;
inline double rad(double deg) { return deg * kPi / 180.0; }

inline double uniform(std::mt19937_64& rng, double a, double b) {
  return std::uniform_real_distribution<double>(a, b)(rng);
}

// (f(h) - f(-h)) / (2 h) for f(s) = the quantity at the base point moved by s along some
// direction.  The result has f's own (evaluated) type, so an Eigen f cannot leave an
// expression that refers to its dead temporaries.
template <class F>
auto central_difference(F&& f, double h) -> std::decay_t<decltype(f(h))> {
  return (f(h) - f(-h)) / (2 * h);
}

// Sets one parameter by name (no validation).  gtest's ASSERT only leaves this function,
// so the failure is recorded and the caller goes on, as with any helper.
inline void set_param(pkm_model* m, const std::string& name, double value, char* err, std::size_t errlen) {
  const int i = pkm_param_index(m, name.c_str());
  ASSERT_GE(i, 0) << "no parameter \"" << name << "\" in robot " << pkm_model_robot(m);
  ASSERT_EQ(pkm_param_set(m, i, value, err, errlen), PKM_OK) << "setting " << name << " = " << value << ": " << err;
}

inline void validate_model(pkm_model* m, char* err, std::size_t errlen) {
  ASSERT_EQ(pkm_model_validate(m, err, errlen), PKM_OK) << "pkm_model_validate(" << pkm_model_robot(m) << "): " << err;
}

using ModelPtr = std::unique_ptr<pkm_model, decltype(&pkm_model_destroy)>;
using DataPtr = std::unique_ptr<pkm_data, decltype(&pkm_data_destroy)>;
using Params = std::vector<std::pair<std::string, double>>;

// A validated model of `robot` (parameter set `set`, nullptr for the robot's default) with
// `params` changed; for code outside a fixture (threads, several models in one test).
inline ModelPtr make_model(const char* robot, const char* set = nullptr, const Params& params = {}) {
  char err[1024] = "";
  ModelPtr m(pkm_model_create(robot, set, err, sizeof err), &pkm_model_destroy);
  EXPECT_NE(m, nullptr) << "pkm_model_create(\"" << robot << "\", " << (set ? set : "default") << "): " << err;
  if (!m) return m;
  for (const auto& p : params) set_param(m.get(), p.first, p.second, err, sizeof err);
  validate_model(m.get(), err, sizeof err);
  return m;
}

inline DataPtr make_data(const pkm_model* m) { return DataPtr(pkm_data_create(m), &pkm_data_destroy); }

// A fixture holding one model `m` and its data `d` for the length of a test (raw pointers
// because every C call takes them; a test may replace d, the fixture frees whatever it
// holds at the end).  Base is ::testing::Test or ::testing::TestWithParam<...>; the
// derived fixture's SetUp calls open(robot, set), or create_model / create_data when
// parameters must change between the two.
template <class Base = ::testing::Test>
struct ModelFixture : Base {
  pkm_model* m = nullptr;
  pkm_data* d = nullptr;
  char err[1024] = {0};
  std::mt19937_64 rng;  // each fixture seeds it in SetUp

  ~ModelFixture() override {
    pkm_data_destroy(d);
    pkm_model_destroy(m);
  }

  void create_model(const char* robot, const char* set = nullptr) {
    m = pkm_model_create(robot, set, err, sizeof err);
    ASSERT_NE(m, nullptr) << "pkm_model_create(\"" << robot << "\", " << (set ? set : "default") << "): " << err;
  }
  void create_data() {
    d = pkm_data_create(m);
    ASSERT_NE(d, nullptr) << "pkm_data_create for robot " << pkm_model_robot(m);
  }
  void open(const char* robot, const char* set = nullptr) {
    create_model(robot, set);
    if (m) create_data();
  }

  double uni(double a, double b) { return uniform(rng, a, b); }

  int index_of(const std::string& name) {
    const int i = pkm_param_index(m, name.c_str());
    EXPECT_GE(i, 0) << "no parameter \"" << name << "\" in robot " << pkm_model_robot(m);
    return i;
  }
  double param(const std::string& name) { return pkm_param_get(m, index_of(name)); }
  // Asserts that the value is accepted; validate() afterwards before computing.
  void set(const std::string& name, double value) { set_param(m, name, value, err, sizeof err); }
  void validate() { validate_model(m, err, sizeof err); }
  // For tests that expect a refusal: the status of setting and then validating (the
  // message is in err).
  int try_set(const std::string& name, double value) {
    const int s = pkm_param_set(m, index_of(name), value, err, sizeof err);
    if (s != PKM_OK) return s;
    return pkm_model_validate(m, err, sizeof err);
  }
};

}  // namespace pkm_test
