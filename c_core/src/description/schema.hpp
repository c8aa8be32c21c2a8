// Reading a description's fields (description.cpp and the joint kinds, description/kind_*.cpp):
// every value checked where it is read, every message "file:line: field: what".
#pragma once

#include <Eigen/Dense>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/robot.hpp"
#include "description/toml_lite.hpp"

namespace pkm {
namespace described {

// "12.5", "-1.0000000001": enough digits that a refused value reads as written.
std::string num(double v);
// "rail[2].qmin" for (rail, 1, qmin).
std::string idx(const char* group, int i, const char* field);

struct Reader {
  const toml::Document& doc;
  [[noreturn]] void fail(int line, const std::string& what) const;
  // The keys a table may have; anything else is refused naming the known ones (typos).
  void only(const toml::Table& t, const std::vector<std::string>& known, const std::string& where) const;
  const toml::Value& need(const toml::Table& t, const std::string& key, const std::string& where,
                          const std::string& what) const;
  std::string text(const toml::Table& t, const std::string& key, const std::string& where, const std::string& what,
                   bool required = true) const;
  double number(const toml::Value& v, const std::string& field) const;
  std::vector<double> numbers(const toml::Value& v, const std::string& field, size_t n) const;
  // Appends a parameter to the table, refused at `line` when v is outside [lo, hi].
  void add(std::vector<ParamSpec>& params, const std::string& name, const char* unit, const std::string& desc,
           double v, double lo, double hi, int line) const;
};

// One [[leg]] table (or one copy of it, turned about world z by `angle`) being read into
// the parameter table: what a joint kind's schema uses.
struct LegSchema {
  const Reader& rd;
  const toml::Table& t;
  int i;              // leg index, 0-based
  double angle;       // copies: rotation about world z [rad]
  std::string where;  // "leg 2 (copy 1 of the [[leg]] on line 7)"
  std::vector<ParamSpec>& params;
  int line_of(const char* key) const;
  // A required 3-vector field, turned with the copy.
  std::vector<double> vec(const char* key, const char* what) const;
  // A required number field in [lo, hi] (lo > 0 reads "must be > 0").
  double scalar(const char* key, const char* what, double lo, double hi, const char* unit) const;
  void add(const std::string& name, const char* unit, const std::string& desc, double v, double lo, double hi,
           int line) const {
    rd.add(params, name, unit, desc, v, lo, hi, line);
  }
  // A unit direction field: refused unless its length is 1 within 1e-6.
  std::vector<double> unit_vec(const char* key, const char* what) const;
};

// Parameter values by name, as a robot's compile() reads them: missing or non-finite
// values are refused naming the robot and the parameter.
struct ParamValues {
  std::string robot;
  std::unordered_map<std::string, double> val;
  ParamValues(const std::string& robot, const std::vector<ParamSpec>& specs, const std::vector<double>& values);
  double operator()(const std::string& name) const;
  // (group[i].<f0>x, y, z)
  Eigen::Vector3d vec(const char* group, int i, const char* f0) const;
  [[noreturn]] void bad(const std::string& msg) const;
};

}  // namespace described
}  // namespace pkm
