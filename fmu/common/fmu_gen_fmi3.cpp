// fmu_gen's FMI 3.0 output: the table's rows grouped into FMI 3.0 variables (arrays), their
// modelDescription.xml and the C table fmu_vars3.h.
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "fmu_gen.hpp"

namespace fmu_gen {

namespace {

// The pose channels are arrays over the platform coordinates however the table writes
// them (one row per coordinate or a {p} family): what each array is.
const std::map<std::string, std::string>& pose_arrays() {
  static const std::map<std::string, std::string> m = {
      {"pose", "platform pose (continuous state)"},
      {"twist", "rate of the platform pose, der(pose) (continuous state)"},
      {"accel", "second derivative of the platform pose, der(twist)"},
      {"pose0", "initial platform pose (default: the home pose)"},
      {"twist0", "initial rate of the platform pose"}};
  return m;
}

}  // namespace

std::vector<Var3> fmi3_variables(const Table& t, pkm_model* model, int nd, const std::string& path) {
  std::vector<Var3> out;
  Var3 time;
  time.name = "time";
  time.causality = "independent";
  time.description = "simulation time";
  time.unit = "s";
  time.kind = "FMU3_TIME";
  out.push_back(time);
  for (size_t k = 0; k < t.vars.size();) {
    const Var& v = t.vars[k];
    Var3 a;
    a.causality = v.causality;
    a.integer = v.integer;
    a.row = k;
    size_t end = k + 1;
    if (pose_arrays().count(v.channel)) {
      while (end < t.vars.size() && t.vars[end].channel == v.channel) ++end;
      for (size_t j = k; j < end; ++j)
        if (t.vars[j].index != (int)(j - k))
          throw Fail(path + ": the rows of channel " + v.channel + " must give the coordinates in order (FMI 3.0 array)");
      if ((int)(end - k) != nd) throw Fail(path + ": channel " + v.channel + " needs one row per coordinate, together");
      a.name = v.channel;
      a.dims = {nd};
      a.description = pose_arrays().at(v.channel) + ":";
      for (int j = 0; j < nd; ++j)
        a.description += std::string(j ? ", " : " ") + pkm_model_pose_name(model, j) +
                         (no_unit(t.vars[k + j].unit) ? "" : " [" + t.vars[k + j].unit + "]");
    } else if (!v.dims.empty()) {
      while (end < t.vars.size() && t.vars[end].line == v.line) ++end;
      a.name = v.family_name;
      a.dims = v.dims;
      a.description = v.family_description;
      for (const char* p : {"{i}", "{j}", "{r}", "{c}"}) a.description = replace_all(a.description, p, std::string(1, p[1]));
      a.description = replace_all(a.description, "{qu}", pkm_model_joint_unit(model));
      a.description = replace_all(a.description, "{eu}", pkm_model_effort_unit(model));
    } else {
      a.name = v.name;
      a.description = v.description;
    }
    a.count = end - k;
    a.unit = v.unit;
    for (size_t j = k; j < end; ++j)
      if (t.vars[j].unit != v.unit) a.unit.clear();  // mixed units (m and rad): said in the description
    out.push_back(a);
    k = end;
  }
  if (t.nindicators() > 0) {
    Var3 z;
    z.name = "eventIndicators";
    z.causality = "local";
    z.kind = "FMU3_INDICATORS";
    z.count = (size_t)t.nindicators();
    z.dims = {t.nindicators()};
    z.description = "Model Exchange event indicators, each > 0 inside the usable workspace: "
                    "singularity.direct - solver.singMin";
    if (!t.qmin.empty()) z.description += ", then per joint i q[i] - qmin[i], qmax[i] - q[i]";
    out.push_back(z);
  }
  return out;
}

std::string model_description3(const Table& t, const std::vector<Var3>& vars, const std::string& token) {
  const std::string id = t.head.at("identifier");
  std::ostringstream o;
  o << description_head(t, "3.0", "instantiationToken", token) << ">\n";
  const char* common =
      " canGetAndSetFMUState=\"true\" canSerializeFMUState=\"true\" providesDirectionalDerivatives=\"false\""
      " canBeInstantiatedOnlyOncePerProcess=\"false\" needsExecutionTool=\"false\"";
  if (!t.controller())
    o << "  <ModelExchange modelIdentifier=\"" << xml(id) << "\"" << common
      << " needsCompletedIntegratorStep=\"true\"/>\n";
  o << "  <CoSimulation modelIdentifier=\"" << xml(id) << "\"" << common
    << " canHandleVariableCommunicationStepSize=\"true\" maxOutputDerivativeOrder=\"0\" hasEventMode=\"false\""
       " providesIntermediateUpdate=\"false\" mightReturnEarlyFromDoStep=\""
    << (t.controller() ? "false" : "true") << "\"/>\n";
  std::set<std::string> units;
  for (const auto& v : vars)
    if (!no_unit(v.unit)) units.insert(v.unit);
  o << units_and_log_categories(units);
  o << "  <ModelVariables>\n";
  std::map<std::string, size_t> vr_of;
  for (size_t k = 0; k < vars.size(); ++k) vr_of[vars[k].name] = k;
  for (size_t k = 0; k < vars.size(); ++k) {
    const Var3& v = vars[k];
    const char* type = v.integer ? "Int32" : "Float64";
    o << "    <" << type << variable_attributes(v.name, k, v.description, v.causality, v.integer);
    if (!v.integer && !no_unit(v.unit)) o << " unit=\"" << xml(v.unit) << "\"";
    if (v.name == "twist" && vr_of.count("pose")) o << " derivative=\"" << vr_of.at("pose") << "\"";
    if (v.name == "accel" && vr_of.count("twist")) o << " derivative=\"" << vr_of.at("twist") << "\"";
    if (v.kind == "FMU3_ROWS" && (v.causality == "parameter" || v.causality == "input")) {
      o << " start=\"";
      for (size_t j = 0; j < v.count; ++j) {
        const Var& r = t.vars[v.row + j];
        o << (j ? " " : "") << (v.integer ? std::to_string((long long)r.start) : num(r.start));
      }
      o << "\"";
    }
    if (v.dims.empty()) {
      o << "/>\n";
    } else {
      o << ">\n";
      for (int d : v.dims) o << "      <Dimension start=\"" << d << "\"/>\n";
      o << "    </" << type << ">\n";
    }
  }
  o << "  </ModelVariables>\n  <ModelStructure>\n";
  for (size_t k = 0; k < vars.size(); ++k)
    if (vars[k].causality == "output") o << "    <Output valueReference=\"" << k << "\"/>\n";
  // The state vector is (pose, twist): its derivatives are (twist, accel) in that order.
  if (!t.controller())
    for (const char* d : {"twist", "accel"})
      o << "    <ContinuousStateDerivative valueReference=\"" << vr_of.at(d) << "\"/>\n";
  // Every output is calculated (states from pose0/twist0, derivatives included).
  for (size_t k = 0; k < vars.size(); ++k)
    if (vars[k].causality == "output") o << "    <InitialUnknown valueReference=\"" << k << "\"/>\n";
  for (size_t k = 0; k < vars.size(); ++k)
    if (vars[k].kind == "FMU3_INDICATORS") o << "    <EventIndicator valueReference=\"" << k << "\"/>\n";
  o << "  </ModelStructure>\n</fmiModelDescription>\n";
  return o.str();
}

std::string vars3_header(const std::vector<Var3>& vars, const std::string& token, const std::string& src) {
  std::ostringstream o;
  o << "/* Generated by fmu_gen from " << src << " and the core's parameter table: do not edit.\n"
    << " * The FMI 3.0 variables of the FMU (its modelDescription.xml comes from the same run),\n"
    << " * each over rows of FMU_MODEL.vars (fmu_vars.h). */\n"
    << "#ifndef PKM_FMU_VARS3_H\n#define PKM_FMU_VARS3_H\n\n#include \"fmu_model.h\"\n\n"
    << "#define FMU3_TOKEN " << cstr(token) << "\n#define FMU3_NVARS " << vars.size() << "\n\n"
    << "static const fmu3_var FMU3_VARS[FMU3_NVARS] = {\n";
  for (size_t k = 0; k < vars.size(); ++k) {
    const Var3& v = vars[k];
    o << "    {" << k << "u, " << cstr(v.name) << ", " << (v.integer ? "FMU_INTEGER" : "FMU_REAL") << ", " << v.kind
      << ", " << v.row << ", " << v.count << "},\n";
  }
  o << "};\n\n#endif\n";
  return o.str();
}

}  // namespace fmu_gen
