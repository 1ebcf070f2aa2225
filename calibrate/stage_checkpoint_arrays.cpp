// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/stage_checkpoint_arrays.hpp"

#include <cmath>
#include <stdexcept>

namespace rbc {

namespace {

[[noreturn]] void bad(const std::string& what) {
  throw std::runtime_error(what);
}

/// rows and cols are bounded by the kMax constants, so rows * cols does not overflow.
template <class T>
void expect_shape(const CheckpointTable<T>& t, std::size_t rows, std::size_t cols,
                  const std::string& name) {
  if (t.rows != rows || t.cols != cols)
    bad(name + " has shape " + std::to_string(t.rows) + " x " + std::to_string(t.cols) +
        ", expected " + std::to_string(rows) + " x " + std::to_string(cols));
  if (t.values.size() != rows * cols)
    bad(name + " holds " + std::to_string(t.values.size()) + " values for its shape " +
        std::to_string(rows) + " x " + std::to_string(cols));
}

bool finite_or_minus_infinity(double v) {
  return std::isfinite(v) || v == -INFINITY;
}

bool whole_number(double v) {
  return std::isfinite(v) && v >= 0 && v <= 9.0e15 && v == std::floor(v);
}

const CheckpointTable<double>* find(const StageCheckpointArrays& a, const std::string& name) {
  for (const auto& [key, table] : a.accumulators)
    if (key == name) return &table;
  return nullptr;
}

void check_tmcmc_accumulators(const StageCheckpointArrays& a) {
  if (a.accumulators.size() != 2) bad("expected the accumulators of tmcmc");
  const auto* island = find(a, "log_evidence_island");
  const auto* delta = find(a, "delta_method_variance");
  if (!island || !delta)
    bad("accumulators log_evidence_island and delta_method_variance are missing");
  if (island->rows < 1 || island->rows > static_cast<std::size_t>(a.samples))
    bad("log_evidence_island has " + std::to_string(island->rows) + " islands");
  expect_shape(*island, island->rows, 1, "accumulator log_evidence_island");
  for (double v : island->values)
    if (!finite_or_minus_infinity(v)) bad("log_evidence_island holds " + std::to_string(v));
  expect_shape(*delta, 1, 1, "accumulator delta_method_variance");
  if (!(std::isfinite(delta->values[0]) && delta->values[0] >= 0))
    bad("delta_method_variance is " + std::to_string(delta->values[0]));
}

}  // namespace

void check_stage_checkpoint_arrays(const StageCheckpointArrays& a) {
  if (a.sampler != "tmcmc") bad("unknown sampler '" + a.sampler + "'");
  if (a.samples < 1 || a.samples > kMaxCheckpointSamples)
    bad("population of " + std::to_string(a.samples) + " samples");
  if (a.dimension < 1 || a.dimension > kMaxCheckpointDimension)
    bad("dimension " + std::to_string(a.dimension));
  if (a.stage < 0 || a.stage > kMaxCheckpointStages) bad("stage " + std::to_string(a.stage));
  const auto n = static_cast<std::size_t>(a.samples), d = static_cast<std::size_t>(a.dimension),
             stages = static_cast<std::size_t>(a.stage) + 1;

  expect_shape(a.theta, n, d, "theta");
  for (double v : a.theta.values)
    if (!std::isfinite(v)) bad("theta holds " + std::to_string(v));
  expect_shape(a.log_likelihood, n, 1, "log_likelihood");
  for (double v : a.log_likelihood.values)
    if (!finite_or_minus_infinity(v)) bad("log_likelihood holds " + std::to_string(v));

  // The warm-state pool.
  if (a.state_offsets.rows < 1) bad("state_offsets is empty");
  if (a.state_offsets.rows - 1 > n)
    bad("state pool has " + std::to_string(a.state_offsets.rows - 1) + " entries for " +
        std::to_string(n) + " samples");
  expect_shape(a.state_offsets, a.state_offsets.rows, 1, "state_offsets");
  const auto& off = a.state_offsets.values;
  if (off.front() != 0) bad("state_offsets does not start at 0");
  for (std::size_t e = 1; e < off.size(); ++e)
    if (off[e] < off[e - 1]) bad("state_offsets decrease at entry " + std::to_string(e));
  const unsigned long long total = off.back();
  if (a.state_values.cols != 1 || a.state_values.rows != (total == 0 ? 1 : total) ||
      a.state_values.values.size() != a.state_values.rows)
    bad("state_values does not hold the " + std::to_string(total) + " values of the offsets");
  for (double v : a.state_values.values)
    if (!std::isfinite(v)) bad("state_values holds " + std::to_string(v));
  expect_shape(a.state_index, n, 1, "state_index");
  for (unsigned long long e : a.state_index.values)
    if (e >= a.state_offsets.rows - 1) bad("state_index " + std::to_string(e) + " out of range");

  // Counters.
  if (a.runs < 0 || a.retried < 0 || a.failed < 0 || a.symmetry_broken < 0 || a.retried > a.runs ||
      a.failed > a.runs || a.symmetry_broken > a.runs)
    bad("forward-run counters runs " + std::to_string(a.runs) + ", retried " +
        std::to_string(a.retried) + ", failed " + std::to_string(a.failed) + ", symmetry broken " +
        std::to_string(a.symmetry_broken));

  // Schedule and stage log.
  expect_shape(a.schedule, stages, 1, "schedule");
  const auto& beta = a.schedule.values;
  if (beta.front() != 0.0) bad("schedule does not start at 0");
  for (std::size_t j = 1; j < stages; ++j)
    if (!(beta[j] > beta[j - 1] && beta[j] <= 1.0))
      bad("schedule is not increasing to at most 1 at stage " + std::to_string(j));
  expect_shape(a.stage_log, stages, kStageLogColumns, "stage_log");
  double runs_before = 0;
  for (std::size_t j = 0; j < stages; ++j) {
    const double* row = a.stage_log.values.data() + j * kStageLogColumns;
    const std::string at = "stage_log row " + std::to_string(j);
    if (row[0] != static_cast<double>(j)) bad(at + " is numbered " + std::to_string(row[0]));
    if (row[1] != beta[j]) bad(at + " disagrees with the schedule");
    for (std::size_t c = 2; c < kStageLogColumns; ++c)
      if (!std::isfinite(row[c])) bad(at + " holds " + std::to_string(row[c]));
    if (row[2] < 0 || row[4] < 0 || row[4] > 1 || row[5] < 0 || row[5] > 1 || row[7] < 0)
      bad(at + " holds a value out of range");
    if (!whole_number(row[6]) || row[6] < runs_before)
      bad(at + " has forward runs " + std::to_string(row[6]));
    runs_before = row[6];
  }
  if (runs_before != static_cast<double>(a.runs))
    bad("stage log ends at " + std::to_string(runs_before) + " forward runs, the counters say " +
        std::to_string(a.runs));

  if (a.sampler == "tmcmc") check_tmcmc_accumulators(a);
}

}  // namespace rbc
