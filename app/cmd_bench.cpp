// `rbc bench`: Google Benchmark timings (speed targets live here, never in tests).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <iomanip>
#include <iostream>
#include <map>
#include <vector>

#include "app/commands.hpp"
#include "core/rest_shape.hpp"
#include "discrete/mc_sampler.hpp"
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

/// Metropolis sweeps at 300 K, zero force, from the rest shape, on state.range(1) OpenMP threads.
/// Two RNG streams whatever the thread count, so both thread counts run the SAME chain and the
/// ratio of their rates is the parallel speed-up. 20 adaptive sweeps first bring the acceptance
/// to its 40 % target (the cost of a move does not depend much on it).
void BM_McSweep(benchmark::State& state) {
  const Network& net = cached_network(static_cast<int>(state.range(0)));
  const int threads = static_cast<int>(state.range(1));
  const int saved_threads = omp_get_max_threads();
  omp_set_num_threads(threads);
  McOptions o;
  o.temperature_K = 300.0;
  o.seed = 1;
  o.streams = 2;
  o.adapt_sweeps = 20;
  LoadState load;
  load.stiffness_scale = 25.0;  // McRunSetup's default
  McSampler mc(net, load, net.rest, o);
  for (int s = 0; s < o.adapt_sweeps; ++s) mc.sweep();
  long long moves = 0, accepted = 0;
  for (auto _ : state) {
    const McSweepStats st = mc.sweep();
    moves += st.attempted;
    accepted += st.accepted;
  }
  omp_set_num_threads(saved_threads);
  state.counters["vertices"] = net.topo.num_vertices;
  state.counters["threads"] = threads;
  state.counters["acceptance"] = moves ? double(accepted) / double(moves) : 0.0;
  state.counters["moves_per_s"] = benchmark::Counter(double(moves), benchmark::Counter::kIsRate);
}

/// The console reporter plus a closing table of the Monte Carlo parallel speed-up: moves/s on
/// 2 threads over moves/s on 1 thread, per network size (from the mc/sweep runs).
class SpeedupReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      const auto n = r.counters.find("vertices"), t = r.counters.find("threads"),
                 rate = r.counters.find("moves_per_s");
      if (r.run_type != Run::RT_Iteration || n == r.counters.end() || t == r.counters.end() ||
          rate == r.counters.end())
        continue;
      rates_[static_cast<int>(n->second.value)][static_cast<int>(t->second.value)] =
          rate->second.value;
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    for (const auto& [n, by_threads] : rates_) {
      const auto one = by_threads.find(1), two = by_threads.find(2);
      if (one == by_threads.end() || two == by_threads.end() || one->second <= 0) continue;
      std::cout << "Monte Carlo N = " << n << ": " << std::fixed << std::setprecision(0)
                << one->second << " moves/s on 1 thread, " << two->second
                << " on 2, parallel speed-up " << std::setprecision(2) << two->second / one->second
                << "x\n";
    }
  }

 private:
  std::map<int, std::map<int, double>> rates_;  // vertices -> threads -> moves/s
};

}  // namespace

void add_bench_command(CLI::App& app, Action& action) {
  auto args = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand(
      "bench",
      "Benchmarks: `rbc bench stretch` (discrete energy+gradient and time to equilibrium "
      "at 88 pN for N = 500, 2000, 8000, 27500), `rbc bench mc` (Monte Carlo vertex moves/s "
      "on 1 and 2 threads, N = 500, 2000, 8000, and the parallel speed-up); extra arguments go "
      "to Google Benchmark");
  cmd->allow_extras();
  cmd->prefix_command();
  cmd->callback([cmd, args, &action] {
    *args = cmd->remaining();
    action = [args]() -> int {
      std::string suite = args->empty() ? "stretch" : args->front();
      if (suite == "stretch") {
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
      } else if (suite == "mc") {
        benchmark::RegisterBenchmark("mc/sweep", BM_McSweep)
            ->ArgNames({"N", "threads"})
            ->ArgsProduct({{500, 2000, 8000}, {1, 2}})
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime()
            ->MinTime(2.0);
      } else {
        throw std::invalid_argument("bench " + suite +
                                    ": unknown benchmark suite (expected "
                                    "stretch or mc)");
      }
      std::vector<std::string> rest(args->begin() + (args->empty() ? 0 : 1), args->end());
      // Google Benchmark's own flags only (--benchmark_filter=..., ...); anything else is refused
      // here, before any benchmark runs, with the one error format of every command.
      for (const auto& s : rest)
        if (s.rfind("--benchmark_", 0) != 0 && s.rfind("--v=", 0) != 0)
          throw std::invalid_argument("bench " + suite + " " + s +
                                      ": not a Google Benchmark option (expected "
                                      "--benchmark_...=VALUE, see --benchmark_list_tests)");
      std::vector<char*> argv{const_cast<char*>("rbc")};  // its messages then start "rbc: "
      for (auto& s : rest) argv.push_back(s.data());
      int argc = static_cast<int>(argv.size());
      benchmark::Initialize(&argc, argv.data());
      if (benchmark::ReportUnrecognizedArguments(argc, argv.data())) return 2;
      SpeedupReporter reporter;
      benchmark::RunSpecifiedBenchmarks(&reporter);
      benchmark::Shutdown();
      return 0;
    };
  });
}

}  // namespace rbc::app
