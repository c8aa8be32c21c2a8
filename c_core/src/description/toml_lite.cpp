#include "description/toml_lite.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <unordered_map>

#include "common/robot.hpp"

namespace pkm {
namespace toml {

const char* Value::kind_name() const {
  switch (kind) {
    case Number: return "a number";
    case String: return "a string";
    case Bool: return "a boolean";
    default: return "an array";
  }
}

const Value* Table::find(const std::string& key) const {
  for (const auto& kv : keys)
    if (kv.first == key) return &kv.second;
  return nullptr;
}

std::vector<const Table*> Document::named(const std::string& name) const {
  std::vector<const Table*> out;
  for (const Table& t : tables)
    if (t.name == name) out.push_back(&t);
  return out;
}

namespace {

// A character as a message shows it.
std::string shown(char c) {
  if (c == '\n') return "the end of the line";
  if (c == '\0') return "the end of the file";
  if (c == '\t') return "a tab";
  if ((unsigned char)c < 32 || (unsigned char)c >= 127) return "a non-ASCII or control byte";
  return std::string("'") + c + "'";
}

struct Parser {
  const std::string& s;
  const std::string& file;
  size_t i = 0;
  int line = 1;

  [[noreturn]] void fail(const std::string& what) const { fail_at(line, what); }
  [[noreturn]] void fail_at(int at, const std::string& what) const {
    throw Error(PKM_ERR_ARGUMENT, file + ":" + std::to_string(at) + ": " + what);
  }
  bool end() const { return i >= s.size(); }
  char peek() const { return end() ? '\0' : s[i]; }
  // Skips blanks and comments on this line.
  void blanks() {
    while (!end()) {
      if (s[i] == ' ' || s[i] == '\t' || s[i] == '\r') {
        ++i;
      } else if (s[i] == '#') {
        while (!end() && s[i] != '\n') ++i;
      } else {
        break;
      }
    }
  }
  // Skips blanks, comments and newlines (inside arrays).
  void space() {
    for (;;) {
      blanks();
      if (peek() == '\n') {
        ++i, ++line;
      } else {
        return;
      }
    }
  }
  void end_of_line() {
    blanks();
    if (end()) return;
    if (s[i] != '\n') fail("unexpected " + shown(s[i]) + " after the value (one key = value per line)");
    ++i, ++line;
  }
  std::string quoted() {
    ++i;  // opening quote
    std::string out;
    while (!end() && s[i] != '"') {
      if (s[i] == '\n') fail("string not closed on its line");
      if (s[i] == '\\') {
        ++i;
        const char c = peek();
        if (c == '"' || c == '\\') out += c;
        else if (c == 'n') out += '\n';
        else if (c == 't') out += '\t';
        else fail("unknown escape \\" + shown(c) + " in a string");
        ++i;
      } else {
        out += s[i++];
      }
    }
    if (end()) fail("string not closed");
    ++i;
    return out;
  }
  std::string key() {
    blanks();
    if (peek() == '"') return quoted();
    std::string out;
    while (!end() && (std::isalnum((unsigned char)s[i]) || s[i] == '_' || s[i] == '-' || s[i] == '.')) out += s[i++];
    if (out.empty()) fail("expected a key, found " + shown(peek()));
    return out;
  }
  Value value() {
    blanks();
    Value v;
    v.line = line;
    const char c = peek();
    if (c == '"') {
      v.kind = Value::String;
      v.str = quoted();
    } else if (c == '[') {
      v.kind = Value::Array;
      ++i;
      space();
      // An array may span lines; one that is never closed is reported where it opens.
      auto broken = [&](const std::string& what) {
        if (line == v.line) fail(what);
        fail_at(v.line, "array not closed (line " + std::to_string(line) + ": " + what + ")");
      };
      while (peek() != ']') {
        if (end()) broken("the file ends");
        Value item = value();
        if (item.kind == Value::Array) fail("nested arrays are not part of a robot description");
        v.items.push_back(std::move(item));
        space();
        if (peek() == ',') {
          ++i;
          space();
        } else if (peek() != ']') {
          broken("expected ',' or ']' in an array, found " + shown(peek()));
        }
      }
      ++i;
    } else if (c == '{') {
      fail("inline tables { ... } are not supported: write the table as its own [section]");
    } else if (s.compare(i, 4, "true") == 0 && !std::isalnum((unsigned char)(i + 4 < s.size() ? s[i + 4] : ' '))) {
      v.kind = Value::Bool, v.b = true, i += 4;
    } else if (s.compare(i, 5, "false") == 0 && !std::isalnum((unsigned char)(i + 5 < s.size() ? s[i + 5] : ' '))) {
      v.kind = Value::Bool, v.b = false, i += 5;
    } else {
      size_t j = i;
      while (j < s.size() && (std::isalnum((unsigned char)s[j]) || s[j] == '.' || s[j] == '+' || s[j] == '-' ||
                              s[j] == '_'))
        ++j;
      std::string tok = s.substr(i, j - i);
      if (tok.empty()) fail("expected a value, found " + shown(c));
      std::string digits;
      for (char ch : tok)
        if (ch != '_') digits += ch;
      // Every spelling strtod reads as non-finite (inf, Infinity, NAN, nan(1), ...), refused
      // here at its own line rather than as a NaN later.
      std::string word;
      for (char ch : digits)
        if (ch != '+' && ch != '-') word += (char)std::tolower((unsigned char)ch);
      if (word == "inf" || word == "infinity" || word == "nan" || word.rfind("nan(", 0) == 0)
        fail("'" + tok + "' is not a finite number");
      errno = 0;
      char* endp = nullptr;
      const double x = std::strtod(digits.c_str(), &endp);
      if (endp != digits.c_str() + digits.size())
        fail("'" + tok + "' is not a number (strings are written in double quotes)");
      if (errno == ERANGE && (x == 0 || std::abs(x) > 1))
        fail("'" + tok + "' is out of the range of a double");
      if (!std::isfinite(x)) fail("'" + tok + "' is not a finite number");
      v.kind = Value::Number;
      v.num = x;
      i = j;
    }
    return v;
  }
  std::string header_name() {
    std::string name;
    for (;;) {
      std::string part = key();
      name += (name.empty() ? "" : ".") + part;
      blanks();
      if (peek() != '.') break;
      ++i;
    }
    return name;
  }

  Document run() {
    Document doc;
    doc.file = file;
    doc.tables.push_back(Table{});
    // Names seen so far (hashed: a file of many keys or tables reads in linear time).
    std::unordered_map<std::string, std::pair<int, bool>> tables;  // name -> line of the first, declared [[ ]]
    std::unordered_map<std::string, int> keys;                     // the current table's keys -> line
    for (;;) {
      space();
      if (end()) break;
      if (peek() == '[') {
        const bool array = (i + 1 < s.size() && s[i + 1] == '[');
        i += array ? 2 : 1;
        Table t;
        t.line = line;
        t.array = array;
        t.name = header_name();
        blanks();
        if (peek() != ']' || (array && (i + 1 >= s.size() || s[i + 1] != ']')))
          fail(std::string("table header not closed with ") + (array ? "']]'" : "']'"));
        i += array ? 2 : 1;
        const auto seen = tables.emplace(t.name, std::make_pair(t.line, array));
        if (!seen.second && (!array || !seen.first->second.second))
          fail("[" + t.name + "] is declared twice (first on line " + std::to_string(seen.first->second.first) + ")");
        keys.clear();
        doc.tables.push_back(std::move(t));
        end_of_line();
        continue;
      }
      const int kline = line;
      std::string k = key();
      blanks();
      if (peek() != '=') fail("expected '=' after key '" + k + "'");
      ++i;
      Value v = value();
      Table& cur = doc.tables.back();
      const auto old = keys.emplace(k, kline);
      if (!old.second)
        fail("key '" + k + "' is given twice in " + (cur.name.empty() ? "the top level" : "[" + cur.name + "]") +
             " (first on line " + std::to_string(old.first->second) + ")");
      v.line = kline;
      cur.keys.emplace_back(std::move(k), std::move(v));
      end_of_line();
    }
    return doc;
  }
};

}  // namespace

Document parse(const std::string& text, const std::string& file) {
  Parser p{text, file};
  return p.run();
}

}  // namespace toml
}  // namespace pkm
