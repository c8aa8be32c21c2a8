// The part of TOML a robot description needs (docs/robots.md): comments, [table],
// [[array-of-tables]], key = value with bare or "quoted" keys, numbers, "strings",
// booleans and (multi-line) arrays of those.  Every value keeps its line so that a
// description's errors name file, line and field.  Anything else (inline tables, dates,
// multi-line strings) is refused with its line rather than misread.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace pkm {
namespace toml {

struct Value {
  enum Kind { Number, String, Bool, Array } kind = Number;
  double num = 0;
  std::string str;
  bool b = false;
  std::vector<Value> items;
  int line = 0;
  const char* kind_name() const;
};

struct Table {
  std::string name;  // "" for the top level, "robot", "sets.heavy", "leg" (one per [[leg]])
  int line = 0;      // line of its header
  bool array = false;  // declared by [[name]]
  std::vector<std::pair<std::string, Value>> keys;
  const Value* find(const std::string& key) const;
};

struct Document {
  std::string file;
  std::vector<Table> tables;  // in file order
  std::vector<const Table*> named(const std::string& name) const;
};

// Throws pkm::Error(PKM_ERR_ARGUMENT, "file:line: what") on a syntax error.
Document parse(const std::string& text, const std::string& file);

}  // namespace toml
}  // namespace pkm
