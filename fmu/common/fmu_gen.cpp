// fmu_gen -- writes an FMU's modelDescription.xml AND the C table of its value
// references (fmu_vars.h) from one source: the model folder's variables.txt plus the
// core's own parameter table (names, units, descriptions, defaults come from pkm.h, they
// are not declared twice).  Run by CMake at build time; see docs/fmu.md.
//
//   fmu_gen <variables.txt> <modelDescription.xml> <fmu_vars.h> [<source md.xml> <source file>...]
//
// Exit status 0 on success; otherwise a message naming the file and line on stderr.
// This file is main; what the other parts do is listed in fmu_gen.hpp.
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "fmu_gen.hpp"
#include "pkm/pkm.h"

using namespace fmu_gen;

namespace {

void write_if_changed(const std::string& path, const std::string& text) {
  std::ifstream in(path);
  std::stringstream old;
  old << in.rdbuf();
  if (in && old.str() == text) return;  // keep the timestamp: no needless rebuilds
  std::ofstream out(path);
  out << text;
  if (!out) throw Fail(path + ": cannot write");
}

}  // namespace

int main(int argc, char** argv) {
  // --fmi3 <modelDescription.xml> <fmu_vars3.h>: the FMI 3.0 description and table too.
  std::string md3, vars3;
  if (argc > 3 && std::string(argv[1]) == "--fmi3") {
    md3 = argv[2];
    vars3 = argv[3];
    argv += 3;
    argc -= 3;
  }
  if (argc < 4 || argc == 5) {
    std::cerr << "usage: fmu_gen [--fmi3 <modelDescription.xml> <fmu_vars3.h>] <variables.txt>"
                 " <modelDescription.xml> <fmu_vars.h> [<source modelDescription.xml> <source file>...]\n";
    return 2;
  }
  pkm_model* model = nullptr;
  try {
    Table t = read_table(argv[1], model);
    int nd = pkm_model_ndof(model), np = pkm_model_nparam(model);
    check(t, nd, argv[1]);
    std::string guid = guid_of(model_description(t, nd, "{}"));
    write_if_changed(argv[2], model_description(t, nd, guid));
    write_if_changed(argv[3], vars_header(t, nd, np, guid, argv[1]));
    // The FMI 3.0 variables always (the binary's FMI 3.0 functions need their table).
    const std::vector<Var3> v3 = fmi3_variables(t, model, nd, argv[1]);
    const std::string token = guid_of(model_description3(t, v3, "{}"));
    if (!md3.empty()) write_if_changed(md3, model_description3(t, v3, token));
    if (!vars3.empty()) write_if_changed(vars3, vars3_header(v3, token, argv[1]));
    if (argc > 5)  // the source-code FMU's description: the same model, its sources listed
      write_if_changed(argv[4], model_description(t, nd, guid, std::vector<std::string>(argv + 5, argv + argc)));
  } catch (const std::exception& e) {
    std::cerr << "fmu_gen: " << e.what() << "\n";
    pkm_model_destroy(model);
    return 1;
  }
  pkm_model_destroy(model);
  return 0;
}
