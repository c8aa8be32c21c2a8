// fmu_gen's text helpers: trimming and splitting table lines, XML and C escapes, numbers,
// SI base units, the GUID hash and the parts both model descriptions share.
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "fmu_gen.hpp"

namespace fmu_gen {

std::string trim(const std::string& s) {
  size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  std::istringstream is(s);
  while (std::getline(is, cur, sep)) out.push_back(trim(cur));
  return out;
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) s.replace(p, from.size(), to);
  return s;
}

std::string xml(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string cstr(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '\n') {
      o += "\\n\" \\\n    \"";  // a long text as one literal per line (it may be a macro's)
      continue;
    }
    if (c == '"' || c == '\\') o += '\\';
    o += c;
  }
  return o + "\"";
}

std::string num(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

// Dimensionless quantities carry no unit attribute.
bool no_unit(const std::string& u) { return u.empty() || u == "1" || u == "-"; }

namespace {

// SI base-unit exponents of a unit string such as "m/s2", "kg.m2", "N.s/m", "kg m^2".
// Returns false for a unit it cannot read (written without BaseUnit then).
bool base_unit(const std::string& unit, std::map<std::string, int>& exps) {
  static const std::map<std::string, std::map<std::string, int>> sym = {
      {"m", {{"m", 1}}},   {"kg", {{"kg", 1}}}, {"s", {{"s", 1}}},  {"A", {{"A", 1}}}, {"K", {{"K", 1}}},
      {"mol", {{"mol", 1}}}, {"cd", {{"cd", 1}}}, {"rad", {{"rad", 1}}},
      {"N", {{"kg", 1}, {"m", 1}, {"s", -2}}},   {"J", {{"kg", 1}, {"m", 2}, {"s", -2}}},
      {"W", {{"kg", 1}, {"m", 2}, {"s", -3}}},   {"Pa", {{"kg", 1}, {"m", -1}, {"s", -2}}},
      {"Hz", {{"s", -1}}}};
  std::string u = unit;
  int sign = 1;
  std::string tok;
  auto flush = [&]() -> bool {
    if (tok.empty()) return true;
    size_t k = 0;
    while (k < tok.size() && std::isalpha((unsigned char)tok[k])) ++k;
    std::string s = tok.substr(0, k), e = tok.substr(k);
    if (!e.empty() && e[0] == '^') e = e.substr(1);
    int p = 1;
    if (!e.empty()) {
      try {
        size_t used = 0;
        p = std::stoi(e, &used);
        if (used != e.size()) return false;
      } catch (...) {
        return false;
      }
    }
    auto it = sym.find(s);
    if (it == sym.end()) return false;
    for (auto& kv : it->second) exps[kv.first] += sign * p * kv.second;
    tok.clear();
    return true;
  };
  for (char c : u) {
    if (c == '.' || c == '*' || c == ' ') {
      if (!flush()) return false;
    } else if (c == '/') {
      if (!flush() || sign < 0) return false;  // one '/' at most
      sign = -1;
    } else {
      tok += c;
    }
  }
  return flush();
}

}  // namespace

// 128-bit FNV-1a of the description text, written as a GUID: the same table and core
// give the same GUID, any change gives another.
std::string guid_of(const std::string& text) {
  uint64_t h1 = 14695981039346656037ull, h2 = 0x6c62272e07bb0142ull;
  for (unsigned char c : text) {
    h1 = (h1 ^ c) * 1099511628211ull;
    h2 = (h2 ^ c) * 0x100000001b3ull + 0x9e3779b97f4a7c15ull;
  }
  char b[64];
  std::snprintf(b, sizeof b, "{%08x-%04x-%04x-%04x-%012llx}", (unsigned)(h1 >> 32), (unsigned)((h1 >> 16) & 0xffff),
                (unsigned)(h1 & 0xffff), (unsigned)(h2 >> 48), (unsigned long long)(h2 & 0xffffffffffffull));
  return b;
}

// <UnitDefinitions> of the units used, <LogCategories> and <DefaultExperiment>: the same
// in the FMI 2.0 and the FMI 3.0 description.
std::string units_and_log_categories(const std::set<std::string>& units) {
  std::ostringstream o;
  if (!units.empty()) {
    o << "  <UnitDefinitions>\n";
    for (const auto& u : units) {
      std::map<std::string, int> e;
      o << "    <Unit name=\"" << xml(u) << "\"";
      if (base_unit(u, e)) {
        o << "><BaseUnit";
        for (const auto& kv : e)
          if (kv.second != 0) o << " " << kv.first << "=\"" << kv.second << "\"";
        o << "/></Unit>\n";
      } else {
        o << "/>\n";
      }
    }
    o << "  </UnitDefinitions>\n";
  }
  o << "  <LogCategories>\n"
       "    <Category name=\"logEvents\" description=\"instantiation, initialization, events\"/>\n"
       "    <Category name=\"logStatusWarning\" description=\"warnings\"/>\n"
       "    <Category name=\"logStatusDiscard\" description=\"a step stopped at a singularity or stroke limit\"/>\n"
       "    <Category name=\"logStatusError\" description=\"errors (bad parameter, bad input, CVODE failure)\"/>\n"
       "    <Category name=\"logStatusFatal\" description=\"fatal errors\"/>\n"
       "    <Category name=\"logFmiCalls\" description=\"every FMI call\"/>\n"
       "  </LogCategories>\n";
  o << "  <DefaultExperiment startTime=\"0\" stopTime=\"1\" stepSize=\"0.001\"/>\n";
  return o.str();
}

}  // namespace fmu_gen
