// fmu_gen.hpp -- what the parts of fmu_gen share (fmu_gen.cpp: main; fmu_gen_table.cpp: reading
// variables.txt; fmu_gen_fmi2.cpp and fmu_gen_fmi3.cpp: the two model descriptions and C tables;
// fmu_gen_text.cpp: text helpers).  A build-time tool, not part of any FMU.
#ifndef PKM_FMU_GEN_HPP
#define PKM_FMU_GEN_HPP

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "pkm/pkm.h"

namespace fmu_gen {

struct Fail : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Var {
  std::string name, causality, channel, unit, description;
  int index = 0;       // within the channel
  bool integer = false;
  bool has_start = false;
  double start = 0;
  // The table line the row comes from and, for a family, its dimensions ({i} ... each one
  // a dimension) and its name and description as written: an FMI 3.0 array.
  int line = 0;
  std::vector<int> dims;
  std::string family_name, family_description;
};

struct Table {
  std::map<std::string, std::string> head;
  std::vector<Var> vars;
  std::vector<int> qmin, qmax;  // core parameter numbers per joint (@joint-limits), or empty
  int nx = 0;                   // controller FMUs: states of the LTI law (@lti-states)
  std::string robot_name;       // the core's name of @robot (a description file's robot.name)
  std::string description;      // @robot given as a description file: its text, packed into the FMU
  bool controller() const { return head.count("kind") && head.at("kind") == "controller"; }
  int nindicators() const { return controller() ? 0 : 1 + (qmin.empty() ? 0 : 2 * (int)qmin.size()); }
};

// One FMI 3.0 variable: consecutive rows of the table taken together (an array over the
// joints, the pose coordinates, a gain matrix; or one scalar), or time, or the event
// indicators.  Value references are positions in this list (time is 0).
struct Var3 {
  std::string name, causality, description, unit, kind = "FMU3_ROWS";
  bool integer = false;
  size_t row = 0, count = 1;  // first row of the FMI 2.0 table (0-based) and the rows
  std::vector<int> dims;      // empty: a scalar
};

// ---------------------------------------------------------------- text (fmu_gen_text.cpp)

std::string trim(const std::string& s);
std::vector<std::string> split(const std::string& s, char sep);
std::string replace_all(std::string s, const std::string& from, const std::string& to);
std::string xml(const std::string& s);  // XML attribute text
std::string cstr(const std::string& s); // a C string literal
std::string num(double v);              // %.17g
// Dimensionless quantities carry no unit attribute.
bool no_unit(const std::string& u);
// 128-bit FNV-1a of the description text, written as a GUID.
std::string guid_of(const std::string& text);
// <UnitDefinitions>, <LogCategories> and <DefaultExperiment> of both descriptions.
std::string units_and_log_categories(const std::set<std::string>& units);
// <fmiModelDescription ...> of both descriptions up to variableNamingConvention (tag left open):
// id_attribute is "guid" (FMI 2.0) or "instantiationToken" (FMI 3.0).
std::string description_head(const Table& t, const std::string& fmi_version, const std::string& id_attribute,
                             const std::string& id_value);
// name, valueReference, description, causality, variability and initial of a variable.
std::string variable_attributes(const std::string& name, size_t vr, const std::string& description,
                                const std::string& causality, bool integer);

// ------------------------------------------------------------- table (fmu_gen_table.cpp)

// Channel name -> (C enum name, is Integer); the model's enum is fmu_channel in fmu_model.h.
const std::map<std::string, std::pair<std::string, bool>>& channels();
// The table of variables.txt at path; creates the core model of its @robot into model.
Table read_table(const std::string& path, pkm_model*& model);
// Throws unless the table describes a complete model.
void check(const Table& t, int nd, const std::string& path);

// ------------------------------------------------------------------ FMI 2.0 (fmu_gen_fmi2.cpp)

// modelDescription.xml; with sources, the source-code FMU's (its files listed).
std::string model_description(const Table& t, int nd, const std::string& guid,
                              const std::vector<std::string>& sources = {});
// fmu_vars.h: the value references, the rows of FMU_VARS[], the joint-limit parameters.
std::string vars_header(const Table& t, int nd, int np, const std::string& guid, const std::string& src);

// ------------------------------------------------------------------ FMI 3.0 (fmu_gen_fmi3.cpp)

std::vector<Var3> fmi3_variables(const Table& t, pkm_model* model, int nd, const std::string& path);
std::string model_description3(const Table& t, const std::vector<Var3>& vars, const std::string& token);
std::string vars3_header(const std::vector<Var3>& vars, const std::string& token, const std::string& src);

}  // namespace fmu_gen

#endif  // PKM_FMU_GEN_HPP
