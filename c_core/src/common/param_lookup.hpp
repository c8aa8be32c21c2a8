// Parameter values by name for the compile() functions that read a block of the model's
// parameter table in the table's own order (the drive layer, the generic joint force, the
// platform force): each search starts where the previous one found its name, so a block read
// in order costs a comparison or two per name instead of a scan of the whole table (a model
// is compiled again at every parameter set a fit tries).  Names in a table are unique: the
// value found is the one a scan from the start finds.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "common/robot.hpp"

namespace pkm {

class InOrderLookup {
 public:
  InOrderLookup(const std::vector<ParamSpec>& specs, const std::vector<double>& values)
      : specs_(specs), values_(values) {}

  // The value of `name`, or nullptr if the table has no such parameter.
  const double* find(const std::string& name) {
    const size_t n = specs_.size();
    for (size_t k = 0; k < n; ++k) {
      const size_t i = next_ + k < n ? next_ + k : next_ + k - n;
      if (specs_[i].name == name) {
        next_ = i + 1 < n ? i + 1 : 0;
        return &values_[i];
      }
    }
    return nullptr;
  }

 private:
  const std::vector<ParamSpec>& specs_;
  const std::vector<double>& values_;
  size_t next_ = 0;
};

}  // namespace pkm
