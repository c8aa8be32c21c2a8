// The one place where C++ exceptions become C status codes (no exception crosses
// the C boundary).
#pragma once

#include <cmath>
#include <cstdio>
#include <cstddef>
#include <cstring>
#include <initializer_list>
#include <new>
#include <string>
#include <utility>

#include "common/handles.hpp"

namespace pkm {

inline void write_err(char* err, size_t errlen, const std::string& msg) {
  if (err && errlen > 0) {
    std::strncpy(err, msg.c_str(), errlen - 1);
    err[errlen - 1] = '\0';
  }
}

// Runs f(); on an exception stores the message into `sink` and returns the status.
template <class F>
int guard_into(std::string& sink, F&& f) {
  try {
    f();
    return PKM_OK;
  } catch (const Error& e) {
    sink = e.what();
    return e.status;
  } catch (const std::bad_alloc&) {
    sink = "out of memory";
    return PKM_ERR_INTERNAL;
  } catch (const std::exception& e) {
    sink = std::string("internal error: ") + e.what();
    return PKM_ERR_INTERNAL;
  } catch (...) {
    sink = "internal error: unknown exception";
    return PKM_ERR_INTERNAL;
  }
}

template <class F>
int guard(pkm_data* d, F&& f) {
  if (!d) return PKM_ERR_ARGUMENT;
  d->error.clear();
  return guard_into(d->error, f);
}

template <class F>
int guard_err(char* err, size_t errlen, F&& f) {
  std::string msg;
  int s = guard_into(msg, f);
  if (s != PKM_OK) write_err(err, errlen, msg);
  return s;
}

// A number as messages print it (precision significant digits, shortest form).
inline std::string num(double v, int precision = 10) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", precision, v);
  return buf;
}

// A check whose message is built only when it fails: a function argument would format
// its numbers on every call, and the success path of an advance must not pay for that.
#define PKM_REQUIRE(ok, status, msg)                    \
  do {                                                  \
    if (!(ok)) throw ::pkm::Error((status), (msg));     \
  } while (0)

// Inputs must be finite: a NaN in is reported, never passed on.
inline void check_finite(const double* v, int n, const char* what) {
  if (!v) throw Error(PKM_ERR_ARGUMENT, std::string(what) + " is NULL");
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i]))
      throw Error(PKM_ERR_ARGUMENT,
                  std::string(what) + "[" + std::to_string(i) + "] is not finite (" +
                      std::to_string(v[i]) + ")");
}

inline void check_out(const void* p, const char* what) {
  if (!p) throw Error(PKM_ERR_ARGUMENT, std::string(what) + " is NULL");
}

// Runs a per-item function over a batch: records each item's status, NaN-fills the
// outputs of a failing item, keeps the first failure's message (prefixed with the item
// index) and returns its status.
template <class F>
int run_batch(pkm_data* d, size_t n, int* status, double* out, int out_stride, F&& item) {
  if (!d) return PKM_ERR_ARGUMENT;
  d->error.clear();
  int first = PKM_OK;
  std::string msg;
  for (size_t k = 0; k < n; ++k) {
    int s = guard_into(msg, [&] { item(k); });
    if (status) status[k] = s;
    if (s != PKM_OK) {
      if (out)
        for (int j = 0; j < out_stride; ++j) out[k * out_stride + j] = std::nan("");
      if (first == PKM_OK) {
        first = s;
        d->error = "item " + std::to_string(k) + ": " + msg;
      }
    }
  }
  return first;
}

// Row k of a batch of rows of nd values, refused unless finite (the message names ``what``).
inline const double* row_at(const double* a, size_t k, int nd, const char* what) {
  const double* r = a + k * nd;
  check_finite(r, nd, what);
  return r;
}

// A batched entry point over rows of nd values: the model prepared once and the arrays
// refused if NULL (one guard, in the order given), then row(rm, k) for each row through
// run_batch, the output out having nd values a row.
template <class Row>
int prepared_batch(const pkm_model* m, pkm_data* d, size_t n, int* status, double* out,
                   std::initializer_list<std::pair<const void*, const char*>> arrays, Row&& row) {
  const RobotModel* rm = nullptr;
  int s = guard(d, [&] {
    rm = &prepare(m, d);
    for (const auto& a : arrays) check_out(a.first, a.second);
  });
  if (s != PKM_OK) return s;
  return run_batch(d, n, status, out, d->ndof, [&](size_t k) { row(*rm, k); });
}

// One input of rows_batch: n rows of nd values, named ``name`` when NULL and ``what`` when a
// row is not finite (pkm.h's messages: "x is NULL", "item 2: pose x[0] is not finite (nan)").
struct BatchRows {
  const double* data;
  const char* name;
  const char* what;
};

// The batched form of a per-row function of N input rows into one output row (nd values
// each): prepared_batch with the inputs then the output out (named out_name) refused if
// NULL, each row's inputs refused unless finite (in the order given), then
// row(rm, in_row..., out_row).
template <size_t N, class Row, size_t... I>
int rows_batch(const pkm_model* m, pkm_data* d, size_t n, int* status, const BatchRows (&in)[N], double* out,
               const char* out_name, Row&& row, std::index_sequence<I...>) {
  const int nd = d ? d->ndof : 0;
  return prepared_batch(m, d, n, status, out, {{in[I].data, in[I].name}..., {out, out_name}},
                        [&](const RobotModel& rm, size_t k) {
    const double* r[N] = {row_at(in[I].data, k, nd, in[I].what)...};  // a braced list: checked in order
    row(rm, r[I]..., out + k * nd);
  });
}

template <size_t N, class Row>
int rows_batch(const pkm_model* m, pkm_data* d, size_t n, int* status, const BatchRows (&in)[N], double* out,
               const char* out_name, Row&& row) {
  return rows_batch(m, d, n, status, in, out, out_name, std::forward<Row>(row), std::make_index_sequence<N>{});
}

}  // namespace pkm
