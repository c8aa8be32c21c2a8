// Reading a description's fields (schema.hpp).
#include "description/schema.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace pkm {
namespace described {

std::string num(double v) {
  // The shortest of 10 or 17 significant digits that reads back as v: a refused
  // -1.0000000001 is shown as written, a round 0.1 stays 0.1.
  std::ostringstream os;
  os.precision(10);
  os << v;
  if (std::strtod(os.str().c_str(), nullptr) != v) {
    os.str("");
    os.precision(17);
    os << v;
  }
  return os.str();
}

std::string idx(const char* group, int i, const char* field) {
  return std::string(group) + "[" + std::to_string(i + 1) + "]." + field;
}

void Reader::fail(int line, const std::string& what) const {
  throw Error(PKM_ERR_ARGUMENT, doc.file + ":" + std::to_string(line) + ": " + what);
}

void Reader::only(const toml::Table& t, const std::vector<std::string>& known, const std::string& where) const {
  for (const auto& kv : t.keys)
    if (std::find(known.begin(), known.end(), kv.first) == known.end()) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      fail(kv.second.line, where + ": unknown field '" + kv.first + "' (known: " + list + ")");
    }
}

const toml::Value& Reader::need(const toml::Table& t, const std::string& key, const std::string& where,
                                const std::string& what) const {
  const toml::Value* v = t.find(key);
  if (!v) fail(t.line, where + ": field '" + key + "' is missing (" + what + ")");
  return *v;
}

std::string Reader::text(const toml::Table& t, const std::string& key, const std::string& where,
                         const std::string& what, bool required) const {
  const toml::Value* v = t.find(key);
  if (!v) {
    if (required) need(t, key, where, what);
    return "";
  }
  if (v->kind != toml::Value::String) fail(v->line, where + "." + key + " must be a string (" + what + ")");
  return v->str;
}

double Reader::number(const toml::Value& v, const std::string& field) const {
  if (v.kind != toml::Value::Number) fail(v.line, field + " must be a number, got " + v.kind_name());
  if (!std::isfinite(v.num)) fail(v.line, field + " = " + num(v.num) + " is not a finite number");
  return v.num;
}

std::vector<double> Reader::numbers(const toml::Value& v, const std::string& field, size_t n) const {
  if (v.kind != toml::Value::Array || v.items.size() != n)
    fail(v.line, field + " must be an array of " + std::to_string(n) + " numbers");
  std::vector<double> out;
  for (const auto& it : v.items) out.push_back(number(it, field));
  return out;
}

void Reader::add(std::vector<ParamSpec>& params, const std::string& name, const char* unit, const std::string& desc,
                 double v, double lo, double hi, int line) const {
  if (!(v >= lo && v <= hi))
    fail(line, name + " = " + num(v) + " " + unit + " is outside [" + num(lo) + ", " + num(hi) + "] (" + desc + ")");
  params.push_back({name, unit, desc, v, lo, hi});
}

int LegSchema::line_of(const char* key) const { return t.find(key) ? t.find(key)->line : t.line; }

std::vector<double> LegSchema::vec(const char* key, const char* what) const {
  const toml::Value& v = rd.need(t, key, where, what);
  const auto x = rd.numbers(v, std::string("leg.") + key, 3);
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * x[0] - s * x[1], s * x[0] + c * x[1], x[2]};
}

double LegSchema::scalar(const char* key, const char* what, double lo, double hi, const char* unit) const {
  const toml::Value& v = rd.need(t, key, where, what);
  const double x = rd.number(v, std::string("leg.") + key);
  if (x < lo || x > hi)
    rd.fail(v.line, where + ": " + key + " = " + num(x) + " " + unit + " must be " +
                        (lo > 0 ? "> 0" : hi < 1e300 ? "in [" + num(lo) + ", " + num(hi) + "]" : ">= " + num(lo)) +
                        " (" + what + ")");
  return x;
}

std::vector<double> LegSchema::unit_vec(const char* key, const char* what) const {
  const auto v = vec(key, what);
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (std::abs(n - 1) > 1e-6) rd.fail(line_of(key), where + ": " + key + " has length " + num(n) + ", must be a unit vector");
  return v;
}

ParamValues::ParamValues(const std::string& r, const std::vector<ParamSpec>& specs, const std::vector<double>& values)
    : robot(r) {
  for (size_t k = 0; k < specs.size() && k < values.size(); ++k) val[specs[k].name] = values[k];
}

double ParamValues::operator()(const std::string& name) const {
  auto it = val.find(name);
  if (it == val.end()) throw Error(PKM_ERR_PARAMETER, robot + " parameter " + name + " is missing from the set");
  if (!std::isfinite(it->second))
    throw Error(PKM_ERR_PARAMETER, robot + " parameter " + name + " is not finite (" + num(it->second) + ")");
  return it->second;
}

Eigen::Vector3d ParamValues::vec(const char* group, int i, const char* f0) const {
  const std::string f(f0);
  return {(*this)(idx(group, i, (f + "x").c_str())), (*this)(idx(group, i, (f + "y").c_str())),
          (*this)(idx(group, i, (f + "z").c_str()))};
}

void ParamValues::bad(const std::string& msg) const { throw Error(PKM_ERR_PARAMETER, robot + ": " + msg); }

}  // namespace described
}  // namespace pkm
