// `rbc bench`: Google Benchmark timings (speed targets live here, never in tests).
#include <benchmark/benchmark.h>

#include <map>
#include <vector>

#include "app/commands.hpp"
#include "core/rest_shape.hpp"
#include "discrete/network.hpp"
#include "discrete/stretch.hpp"

namespace rbc::app {
namespace {

const Network& cached_network(int n) {
  // Benchmarks re-enter with the same N; the rest shape is built once per N per process.
  static std::map<int, Network> cache;
  auto it = cache.find(n);
  if (it == cache.end()) {
    RestShapeOptions ro;
    ro.target_vertices = n;
    it = cache.emplace(n, build_network(make_rest_shape(ro), NetworkParameters{})).first;
  }
  return it->second;
}

void BM_DiscreteEnergyGradient(benchmark::State& state) {
  const Network& net = cached_network(static_cast<int>(state.range(0)));
  Positions x = net.rest, g;
  LoadState load;
  load.force_pN = 88.0;
  for (auto _ : state) benchmark::DoNotOptimize(network_energy(net, x, load, &g));
  state.counters["vertices"] = net.topo.num_vertices;
  state.counters["ns_per_vertex"] = benchmark::Counter(
      static_cast<double>(net.topo.num_vertices) * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_DiscreteStretch88(benchmark::State& state) {
  const Network& net = cached_network(static_cast<int>(state.range(0)));
  StretchOptions so;
  for (auto _ : state) {
    Positions x = net.rest;
    ConstraintMultipliers lambda;
    const StretchPoint p = solve_equilibrium(net, 88.0, x, lambda, so);
    state.counters["iterations"] = p.iterations;
    state.counters["factorisations"] = p.factorisations;
    state.counters["converged"] = p.converged;
    state.counters["axial_um"] = p.axial_um;
  }
  state.counters["vertices"] = net.topo.num_vertices;
}

}  // namespace

void add_bench_command(CLI::App& app, Action& action) {
  auto args = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand(
      "bench",
      "Benchmarks: `rbc bench stretch` (discrete energy+gradient and time to equilibrium "
      "at 88 pN for N = 500, 2000, 8000, 27500); extra arguments go to Google Benchmark");
  cmd->allow_extras();
  cmd->prefix_command();
  cmd->callback([cmd, args, &action] {
    *args = cmd->remaining();
    action = [args]() -> int {
      std::string suite = args->empty() ? "stretch" : args->front();
      if (suite != "stretch")
        throw std::invalid_argument("unknown benchmark suite '" + suite + "' (expected stretch)");
      benchmark::RegisterBenchmark("discrete/energy_gradient", BM_DiscreteEnergyGradient)
          ->Arg(500)
          ->Arg(2000)
          ->Arg(8000)
          ->Arg(27500)
          ->Unit(benchmark::kMicrosecond);
      benchmark::RegisterBenchmark("discrete/stretch_88pN", BM_DiscreteStretch88)
          ->Arg(500)
          ->Arg(2000)
          ->Arg(8000)
          ->Arg(27500)
          ->Unit(benchmark::kSecond)
          ->Iterations(1);
      std::vector<char*> argv{const_cast<char*>("rbc-bench")};
      std::vector<std::string> rest(args->begin() + (args->empty() ? 0 : 1), args->end());
      for (auto& s : rest) argv.push_back(s.data());
      int argc = static_cast<int>(argv.size());
      benchmark::Initialize(&argc, argv.data());
      if (benchmark::ReportUnrecognizedArguments(argc, argv.data())) return 2;
      benchmark::RunSpecifiedBenchmarks();
      benchmark::Shutdown();
      return 0;
    };
  });
}

}  // namespace rbc::app
