// Shared by the C++ benchmark programs of bench/ (not a benchmark itself: CMake builds
// only bench/*.cpp): the 6-PUS size, a monotonic clock and the one-line failure exit.
#pragma once

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace bench {

constexpr int N = 6;  // 6-PUS joints and pose coordinates
constexpr double kPi = 3.14159265358979323846;

inline double now() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

// Prints "<program>: <what>" and exits with status 2 (a benchmark that cannot run).
[[noreturn]] inline void die(const char* program, const std::string& what) {
  std::fprintf(stderr, "%s: %s\n", program, what.c_str());
  std::exit(2);
}

}  // namespace bench
