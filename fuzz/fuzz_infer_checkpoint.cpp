// SPDX-License-Identifier: GPL-3.0-or-later
// Fuzz target: the checks applied to the arrays of an `rbc infer` stage checkpoint
// (calibrate/stage_checkpoint_arrays.cpp, check_stage_checkpoint_arrays) before
// `rbc infer --resume` uses them. The input bytes are read as a list of edits to a valid
// checkpoint (6 samples, 2 parameters, stage 2, 2 islands, 3 distinct warm states); the empty
// input is that valid checkpoint and every edit changes one count, shape or value (NaN,
// infinities, huge, negative, off by one). The only allowed failure is std::runtime_error; an
// accepted set must be safe to index the way read_stage_checkpoint does (asserted below with
// __builtin_trap).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "calibrate/stage_checkpoint_arrays.hpp"

namespace {

struct Bytes {
  const std::uint8_t* p;
  std::size_t n;
  bool empty() const { return n == 0; }
  std::uint8_t next() {
    if (n == 0) return 0;
    --n;
    return *p++;
  }
};

rbc::StageCheckpointArrays valid() {
  rbc::StageCheckpointArrays a;
  a.sampler = "tmcmc";
  a.stage = 2;
  a.samples = 6;
  a.dimension = 2;
  a.theta = {{0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2}, 6, 2};
  a.log_likelihood = {{-1, -2, -3, -INFINITY, -5, -6}, 6, 1};
  a.state_index = {{0, 1, 1, 2, 0, 1}, 6, 1};
  a.state_offsets = {{0, 3, 6, 6}, 4, 1};
  a.state_values = {{1, 2, 3, 4, 5, 6}, 6, 1};
  a.schedule = {{0, 0.25, 0.75}, 3, 1};
  a.stage_log = {{0, 0,    0, 0,    0,   1,   6,  0.1,  //
                  1, 0.25, 1, -0.5, 0.4, 0.6, 12, 0.2,  //
                  2, 0.75, 1, -0.7, 0.3, 0.5, 18, 0.3},
                 3,
                 rbc::kStageLogColumns};
  a.accumulators = {{"log_evidence_island", {{-1.2, -1.3}, 2, 1}},
                    {"delta_method_variance", {{0.01}, 1, 1}}};
  a.runs = 18;
  a.retried = 1;
  a.failed = 1;
  return a;
}

double special(std::uint8_t b) {
  switch (b % 12) {
    case 0:
      return std::numeric_limits<double>::quiet_NaN();
    case 1:
      return INFINITY;
    case 2:
      return -INFINITY;
    case 3:
      return 1e308;
    case 4:
      return -1;
    case 5:
      return 0;
    case 6:
      return 1;
    case 7:
      return 2;
    case 8:
      return 1e19;
    default:
      return (double(b) - 128.0) * 0.125;
  }
}

long long count(std::uint8_t b) {
  static const long long values[] = {-1, 0, 1, 2, 3, 5, 6, 7, 64, 65, 1LL << 40, -(1LL << 62)};
  return values[b % 12];
}

template <class T>
void edit_table(rbc::CheckpointTable<T>& t, Bytes& in) {
  const std::uint8_t what = in.next();
  switch (what % 5) {
    case 0:
      t.rows = static_cast<std::size_t>(in.next() % 9);
      break;
    case 1:
      t.cols = static_cast<std::size_t>(in.next() % 10);
      break;
    case 2:
      t.values.resize(static_cast<std::size_t>(in.next() % 30));
      break;
    case 3:
      if (!t.values.empty()) {
        const std::size_t at = in.next() % t.values.size();
        if constexpr (std::is_floating_point_v<T>)
          t.values[at] = special(in.next());
        else
          t.values[at] = static_cast<T>(count(in.next()));
      }
      break;
    default:
      t.rows = static_cast<std::size_t>(1) << (in.next() % 64);  // huge
      break;
  }
}

void edit(rbc::StageCheckpointArrays& a, Bytes& in) {
  const std::uint8_t field = in.next();
  switch (field % 17) {
    case 0:
      a.sampler = in.next() % 2 ? "" : "smc";
      break;
    case 1:
      a.stage = count(in.next());
      break;
    case 2:
      a.samples = count(in.next());
      break;
    case 3:
      a.dimension = count(in.next());
      break;
    case 4:
      edit_table(a.theta, in);
      break;
    case 5:
      edit_table(a.log_likelihood, in);
      break;
    case 6:
      edit_table(a.state_index, in);
      break;
    case 7:
      edit_table(a.state_offsets, in);
      break;
    case 8:
      edit_table(a.state_values, in);
      break;
    case 9:
      edit_table(a.schedule, in);
      break;
    case 10:
      edit_table(a.stage_log, in);
      break;
    case 11:
    case 12:
      if (!a.accumulators.empty())
        edit_table(a.accumulators[field % a.accumulators.size()].second, in);
      break;
    case 13:
      if (!a.accumulators.empty()) a.accumulators[in.next() % a.accumulators.size()].first = "x";
      break;
    case 14:
      if (in.next() % 2) {
        if (!a.accumulators.empty()) a.accumulators.pop_back();
      } else {
        a.accumulators.push_back({"extra", {{1}, 1, 1}});
      }
      break;
    case 15:
      a.runs = count(in.next());
      break;
    default:
      (in.next() % 2 ? a.failed : a.retried) = count(in.next());
      break;
  }
}

/// What read_stage_checkpoint and run_tmcmc do with accepted arrays must be safe.
void use(const rbc::StageCheckpointArrays& a) {
  const auto n = static_cast<std::size_t>(a.samples), d = static_cast<std::size_t>(a.dimension);
  if (a.theta.values.size() != n * d || a.log_likelihood.values.size() != n) __builtin_trap();
  for (double v : a.theta.values)
    if (!std::isfinite(v)) __builtin_trap();
  for (double v : a.log_likelihood.values)
    if (std::isnan(v) || v == INFINITY) __builtin_trap();
  if (a.state_index.values.size() != n) __builtin_trap();
  const auto& off = a.state_offsets.values;
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned long long e = a.state_index.values[i];
    if (e + 1 >= off.size()) __builtin_trap();
    if (off[e] > off[e + 1] || off[e + 1] > a.state_values.values.size()) __builtin_trap();
  }
  const std::size_t stages = static_cast<std::size_t>(a.stage) + 1;
  if (a.schedule.values.size() != stages ||
      a.stage_log.values.size() != stages * rbc::kStageLogColumns)
    __builtin_trap();
  if (a.schedule.values[0] != 0 || a.schedule.values.back() > 1) __builtin_trap();
  for (std::size_t j = 1; j < stages; ++j)
    if (!(a.schedule.values[j] > a.schedule.values[j - 1])) __builtin_trap();
  if (a.failed > a.runs || a.retried > a.runs || a.runs < 0) __builtin_trap();
  std::size_t islands = 0, deltas = 0;
  for (const auto& [name, t] : a.accumulators) {
    if (name == "log_evidence_island") islands = t.values.size();
    if (name == "delta_method_variance") deltas = t.values.size();
    for (double v : t.values)
      if (std::isnan(v) || v == INFINITY) __builtin_trap();
  }
  if (islands < 1 || deltas != 1) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in{data, size};
  rbc::StageCheckpointArrays a = valid();
  for (int k = 0; k < 8 && !in.empty(); ++k) edit(a, in);
  try {
    rbc::check_stage_checkpoint_arrays(a);
  } catch (const std::runtime_error&) {
    return 0;
  }
  use(a);
  return 0;
}
