// SPDX-License-Identifier: GPL-3.0-or-later
#include "app/bench_infer.hpp"

#include <benchmark/benchmark.h>

#include "calibrate/infer.hpp"
#include "compare/experiment.hpp"

namespace rbc::app {
namespace {

/// range(0): 0 = TMCMC, 1 = laplace-is (its default adaptation rounds); range(1): the data,
/// 0 = the default table (Suresh 2005), 1 = Mills 2004 Fig. 8. Everything else is the default
/// calibration. The posterior's summaries are counters (not rates), so the rows of one run can
/// be compared directly: their medians and 90 % intervals should agree within the samplers'
/// Monte Carlo error (calibrate/laplace_is.hpp measures it).
void BM_InferDefault(benchmark::State& state) {
  InferOptions o;
  o.sampler_kind = state.range(0) == 0 ? SamplerKind::tmcmc : SamplerKind::laplace_is;
  if (state.range(1) == 1)
    o.data_file = default_data_directory() + "/mills2004_fig8_optical_tweezers.csv";
  InferenceResult r;
  for (auto _ : state) r = run_inference(o);
  state.counters["forward_runs"] = static_cast<double>(r.counts.runs);
  state.counters["log_evidence"] = r.log_evidence;
  state.counters["log_evidence_sd"] = r.log_evidence_sd;
  if (o.sampler_kind == SamplerKind::laplace_is) state.counters["ess"] = r.ess;
  const auto put = [&state](const Summary& s) {
    state.counters[s.name + "_q05"] = s.q05;
    state.counters[s.name + "_q50"] = s.q50;
    state.counters[s.name + "_q95"] = s.q95;
  };
  for (const Summary& s : r.parameters) put(s);
  put(r.mu);
  state.SetLabel(to_string(o.sampler_kind) +
                 (state.range(1) == 1 ? ", Mills 2004" : ", Suresh 2005"));
}

}  // namespace

void register_infer_benchmarks(std::vector<std::string>& families) {
  families.emplace_back("infer/default_calibration");
  benchmark::RegisterBenchmark("infer/default_calibration", BM_InferDefault)
      ->ArgNames({"sampler", "data"})
      ->ArgsProduct({{0, 1}, {0, 1}})
      ->Unit(benchmark::kSecond)
      ->Iterations(1)
      ->UseRealTime();
}

}  // namespace rbc::app
