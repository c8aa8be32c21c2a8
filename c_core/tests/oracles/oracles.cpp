// The hand-written robots kept as test oracles of the robots the core serves from their
// descriptions (robots/registry.cpp's hook for them): built into libpkm_oracle.so only,
// which the C++ tests and the benchmarks link (bench/described_bench.cpp compares them).
#include "common/robot.hpp"

namespace pkm {

const Robot* oracle_6pus();
const Robot* oracle_quattro();

int oracle_robot_count() { return 2; }
const Robot* oracle_robot_at(int i) { return i == 0 ? oracle_6pus() : i == 1 ? oracle_quattro() : nullptr; }

}  // namespace pkm
