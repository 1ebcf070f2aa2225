// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc bench`: Google Benchmark timings (speed targets live here, never in tests).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <chrono>

#include "app/bench_infer.hpp"
#include "app/commands.hpp"
#include "continuum/adapted_mesh.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/dynamics.hpp"
#include "continuum/loop_bending.hpp"
#include "continuum/loop_stretch.hpp"
#include "core/blas_threads.hpp"
#include "core/rest_shape.hpp"
#include "discrete/hmc_sampler.hpp"
#include "discrete/mc_run.hpp"
#include "discrete/mc_sampler.hpp"
#include "discrete/network.hpp"
#include "discrete/newton_preconditioner.hpp"
#include "discrete/stretch.hpp"
#include "homogenise/invariant_laws.hpp"

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

/// One application of the stretch's Newton preconditioner (a solve with its Cholesky factor and
/// the Woodbury correction) at the rest shape of range(0) vertices; range(1) = 0 solves in
/// double, 1 in single precision (SolvePrecision).
void BM_DiscretePreconditionerApply(benchmark::State& state) {
  const Network& net = cached_network(static_cast<int>(state.range(0)));
  NewtonPreconditionerOptions o;
  o.solve_precision =
      state.range(1) == 1 ? SolvePrecision::single_precision : SolvePrecision::double_precision;
  NewtonPreconditioner pre(net, o);
  if (!pre.refresh(net.rest, ConstraintMultipliers{}, 1.0)) {
    state.SkipWithError("the preconditioner's factorisation failed");
    return;
  }
  Eigen::VectorXd v = Eigen::VectorXd::Ones(3 * net.topo.num_vertices);
  for (auto _ : state) {
    Eigen::VectorXd w = v;
    pre.apply(w);
    benchmark::DoNotOptimize(w.data());
  }
  state.counters["vertices"] = net.topo.num_vertices;
  state.counters["factor_entries"] = pre.statistics().factor_nonzeros;
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

/// The 13 forces of the stretch data (pN, Suresh et al. 2005), the CLI's default list.
const std::vector<double> kMillsForces{0,    16,    19.5, 30.6, 38,    46.6, 67.6,
                                       87.6, 108.8, 130,  151,  172.8, 193};

double seconds_of(const std::function<void()>& run) {
  const auto t0 = std::chrono::steady_clock::now();
  run();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// The cold reference of the warm rows' cold_ratio: the fastest of three runs (s). A single
/// run, the first of its kind in the process, also paid one-time costs (first touches of the
/// factor's memory, the thread team's start) and swung the ratio by +-15 % run to run.
double cold_seconds(const std::function<void()>& run) {
  double best = seconds_of(run);
  for (int k = 1; k < 3; ++k) best = std::min(best, seconds_of(run));
  return best;
}

/// Wall time (s) of one energy + gradient evaluation, the median of 7 batches: the unit in
/// which every sweep row is also reported (a machine-independent measure of solver work).
double evaluation_seconds(const std::function<void()>& eval) {
  std::vector<double> t;
  for (int b = 0; b < 7; ++b) {
    int reps = 0;
    const double s = seconds_of([&] {
      const auto t0 = std::chrono::steady_clock::now();
      do {
        eval();
        ++reps;
      } while (std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(20));
    });
    t.push_back(s / reps);
  }
  std::sort(t.begin(), t.end());
  return t[3];
}

/// The continuum model of a bench row; orientation mirror_planes also cuts the bead patches
/// between x levels (TweezersParameters::keep_equal_x_together), as `rbc stretch` does.
const ContinuumModel& cached_continuum(
    int elements, double persistence_factor = 1.0,
    TriangulationOrientation orientation = TriangulationOrientation::dimple_vertex) {
  static std::map<std::tuple<int, double, TriangulationOrientation>, ContinuumModel> cache;
  const auto key = std::make_tuple(elements, persistence_factor, orientation);
  auto it = cache.find(key);
  if (it == cache.end()) {
    WlcParameters w;
    w.persistence_um *= persistence_factor;
    const IsotropicMembraneLaw law = make_membrane_law(w, StericParameters{}, WlcExpansion::order2);
    ContinuumParameters cp;
    cp.tweezers.keep_equal_x_together = orientation == TriangulationOrientation::mirror_planes;
    it = cache
             .emplace(key,
                      build_continuum_model(make_continuum_mesh(elements, 0, orientation), law, cp))
             .first;
  }
  return it->second;
}

/// The mesh orientation of a continuum bench row: its symmetry argument 2 is the mirror path
/// on the mirror-planes triangulation (`--mesh-orientation mirror-planes`).
TriangulationOrientation bench_orientation(const benchmark::State& state, int index) {
  return state.range(index) == 2 ? TriangulationOrientation::mirror_planes
                                 : TriangulationOrientation::dimple_vertex;
}

const Network& cached_network_p(int n, double persistence_factor) {
  static std::map<std::pair<int, double>, Network> cache;
  const auto key = std::make_pair(n, persistence_factor);
  auto it = cache.find(key);
  if (it == cache.end()) {
    RestShapeOptions ro;
    ro.target_vertices = n;
    NetworkParameters p;
    p.wlc.persistence_um *= persistence_factor;
    it = cache.emplace(key, build_network(make_rest_shape(ro), p)).first;
  }
  return it->second;
}

void set_sweep_counters(benchmark::State& state, double seconds, double eval_s, int iterations,
                        bool converged, int vertices) {
  state.counters["seconds"] = seconds;
  state.counters["eg_evals"] = seconds / eval_s;  // time in energy+gradient evaluations
  state.counters["iterations"] = iterations;
  state.counters["converged"] = converged;
  state.counters["vertices"] = vertices;
}

double continuum_eval_seconds(const ContinuumModel& m) {
  Positions g;
  return evaluation_seconds(
      [&] { benchmark::DoNotOptimize(continuum_energy(m, m.rest, 88.0, &g)); });
}

double network_eval_seconds(const Network& net) {
  Positions g;
  LoadState load;
  load.force_pN = 88.0;
  return evaluation_seconds(
      [&] { benchmark::DoNotOptimize(network_energy(net, net.rest, load, &g)); });
}

/// Continuum options of a bench row: range(index) = 1 solves on the mirror-symmetric states
/// (NewtonOptions::symmetry), 2 the same on the mirror-planes mesh (bench_orientation), 0 (or
/// no such argument) the full problem.
ContinuumOptions continuum_options(const benchmark::State& state, int index) {
  ContinuumOptions o;
  if (state.range(index) >= 1) o.newton.symmetry = Symmetry::mirror;
  return o;
}

/// Trade-off rows: continuum p = 2 over forces from rest (continuation), range(0) elements,
/// range(1) = number of leading Mills forces (13 = all; 8 = 0..87.6 pN is not the
/// 8-force list of the sweep rows, which is {0,16,38,67.6,87.6,130,172.8,193}: range(1) = 0 selects
/// that).
void BM_ContinuumSweep(benchmark::State& state) {
  const ContinuumModel& m =
      cached_continuum(static_cast<int>(state.range(0)), 1.0, bench_orientation(state, 2));
  std::vector<double> forces = kMillsForces;
  if (state.range(1) == 0) forces = {0, 16, 38, 67.6, 87.6, 130, 172.8, 193};
  const ContinuumOptions co = continuum_options(state, 2);
  const double eval_s = continuum_eval_seconds(m);
  for (auto _ : state) {
    std::vector<ContinuumStretchPoint> pts;
    const double s = seconds_of([&] { pts = run_continuum_stretch(m, forces, co); });
    int it = 0;
    bool ok = true;
    for (const auto& p : pts) it += p.iterations, ok = ok && p.converged;
    set_sweep_counters(state, s, eval_s, it, ok, static_cast<int>(m.rest.cols()));
  }
}

/// Continuum 88 pN from the 0 pN equilibrium (range(0) elements; range(1) symmetry).
void BM_Continuum88From0(benchmark::State& state) {
  const ContinuumModel& m =
      cached_continuum(static_cast<int>(state.range(0)), 1.0, bench_orientation(state, 1));
  const ContinuumOptions co = continuum_options(state, 1);
  const auto rest = run_continuum_stretch(m, {0.0}, co);
  const double eval_s = continuum_eval_seconds(m);
  for (auto _ : state) {
    std::vector<ContinuumStretchPoint> pts;
    const double s = seconds_of([&] {
      pts = run_continuum_stretch(m, {88.0}, co, {},
                                  StretchState{{88.0}, {rest[0].x}, {rest[0].multipliers}});
    });
    state.counters["factorisations"] = pts[0].factorisations;
    set_sweep_counters(state, s, eval_s, pts[0].iterations, pts[0].converged,
                       static_cast<int>(m.rest.cols()));
  }
}

/// Continuum options of a warm row: range(1) as continuum_options; range(2) = 1 (if given)
/// checks only the highest force's symmetric equilibrium (SymmetryCheckAt::highest_force, as
/// the calibration does), in the cold reference and the warm run alike.
ContinuumOptions warm_options(const benchmark::State& state) {
  ContinuumOptions o = continuum_options(state, 1);
  if (state.range(2) == 1) o.symmetry_check_at = SymmetryCheckAt::highest_force;
  // A parameter loop reads diameters and states: no per-element fields, in the warm run and
  // its cold reference alike.
  o.element_fields = false;
  return o;
}

/// Warm re-solve of the 13 forces after a 1 % persistence-length change, from the previous
/// parameters' equilibria; `cold_ratio` is its time over the cold 13-force sweep's.
void BM_ContinuumWarm(benchmark::State& state) {
  const int e = static_cast<int>(state.range(0));
  const ContinuumOptions co = warm_options(state);
  const ContinuumModel& m0 = cached_continuum(e, 1.0, bench_orientation(state, 1));
  const ContinuumModel& m1 = cached_continuum(e, 1.01, bench_orientation(state, 1));
  const StretchState before = stretch_state(run_continuum_stretch(m0, kMillsForces, co));
  const double eval_s = continuum_eval_seconds(m1);
  const double cold_s = cold_seconds([&] { run_continuum_stretch(m1, kMillsForces, co); });
  for (auto _ : state) {
    std::vector<ContinuumStretchPoint> pts;
    const double s =
        seconds_of([&] { pts = run_continuum_stretch(m1, kMillsForces, co, {}, before); });
    int it = 0, fact = 0, cg = 0;
    bool ok = true;
    for (const auto& p : pts)
      it += p.iterations, fact += p.factorisations, cg += p.krylov_iterations,
          ok = ok && p.converged;
    state.counters["factorisations"] = fact;
    state.counters["krylov_iterations"] = cg;
    set_sweep_counters(state, s, eval_s, it, ok, static_cast<int>(m1.rest.cols()));
    state.counters["cold_ratio"] = s / cold_s;
  }
}

/// The warm re-solve of BM_ContinuumWarm by a ContinuumSweepSolver: the cold run at the old
/// parameters (not timed) keeps each force's factorisation, the warm run starts from it.
void BM_ContinuumWarmKept(benchmark::State& state) {
  const int e = static_cast<int>(state.range(0));
  const ContinuumOptions co = warm_options(state);
  const ContinuumModel& m0 = cached_continuum(e, 1.0, bench_orientation(state, 1));
  const ContinuumModel& m1 = cached_continuum(e, 1.01, bench_orientation(state, 1));
  const double eval_s = continuum_eval_seconds(m1);
  const double cold_s = cold_seconds([&] { run_continuum_stretch(m1, kMillsForces, co); });
  for (auto _ : state) {
    ContinuumSweepSolver sweep(co);
    const StretchState before = stretch_state(sweep.run(m0, kMillsForces));
    std::vector<ContinuumStretchPoint> pts;
    const double s = seconds_of([&] { pts = sweep.run(m1, kMillsForces, {}, before); });
    int it = 0, fact = 0, cg = 0;
    bool ok = true;
    for (const auto& p : pts)
      it += p.iterations, fact += p.factorisations, cg += p.krylov_iterations,
          ok = ok && p.converged;
    set_sweep_counters(state, s, eval_s, it, ok, static_cast<int>(m1.rest.cols()));
    state.counters["factorisations"] = fact;
    state.counters["krylov_iterations"] = cg;
    state.counters["cold_ratio"] = s / cold_s;
  }
}

/// The recovery speed row: shape recovery after release from the 88 pN equilibrium, range(0)
/// elements (1000 = the 1 % resolution, p = 2), dt = 1 ms for range(1) ms of simulated time
/// (1000 = 1 s), eta_m = 0.7 pN s/um; the static equilibrium is not timed.
void BM_ContinuumRecovery(benchmark::State& state) {
  const ContinuumModel& m = cached_continuum(static_cast<int>(state.range(0)));
  const auto pts = run_continuum_stretch(m, {88.0}, ContinuumOptions{});
  TrajectoryOptions to;
  to.dt_s = 1e-3;
  to.duration_s = 1e-3 * static_cast<double>(state.range(1));
  for (auto _ : state) {
    ContinuumDynamics dyn(m, ContinuumDynamicsOptions{});
    DynamicsState s{pts[0].x, pts[0].multipliers};
    TrajectoryResult r;
    const double secs = seconds_of([&] {
      r = run_trajectory([&](double h, DynamicsState& st) { return dyn.step(0.0, h, st); },
                         [&](const DynamicsState& st) { return dyn.measure(0.0, st); }, s, to);
    });
    const auto& c = dyn.counters();
    state.counters["seconds"] = secs;
    state.counters["steps"] = static_cast<double>(c.steps);
    state.counters["newton_iterations"] = static_cast<double>(c.iterations);
    state.counters["factorisations"] = static_cast<double>(c.factorisations);
    state.counters["chord_steps"] = static_cast<double>(c.chord_steps);
    state.counters["converged"] = r.converged && pts[0].converged;
    state.counters["axial_um"] = r.samples.back().axial_um;
    state.counters["vertices"] = static_cast<double>(m.rest.cols());
  }
}

/// Discrete stretch options of a bench row: range(index) = 1 solves on the mirror-symmetric
/// states (StretchOptions::symmetry), 0 the full problem.
StretchOptions discrete_options(const benchmark::State& state, int index) {
  StretchOptions o;
  if (state.range(index) == 1) o.symmetry = Symmetry::mirror;
  return o;
}

/// Discrete 13-force sweep from rest (range(0) vertices, range(1) preconditioner threshold,
/// range(2) symmetry).
void BM_DiscreteSweep(benchmark::State& state) {
  const Network& net = cached_network_p(static_cast<int>(state.range(0)), 1.0);
  const double eval_s = network_eval_seconds(net);
  StretchOptions so = discrete_options(state, 2);
  if (state.range(1) >= 0) so.precondition_min_vertices = static_cast<int>(state.range(1));
  for (auto _ : state) {
    std::vector<StretchPoint> pts;
    const double s = seconds_of([&] { pts = run_stretch(net, kMillsForces, so); });
    int it = 0;
    bool ok = true;
    for (const auto& p : pts) it += p.iterations, ok = ok && p.converged;
    set_sweep_counters(state, s, eval_s, it, ok, net.topo.num_vertices);
  }
}

/// Discrete 88 pN from the 0 pN equilibrium (range(0) vertices; range(1) symmetry, of both
/// solves).
void BM_Discrete88From0(benchmark::State& state) {
  const Network& net = cached_network_p(static_cast<int>(state.range(0)), 1.0);
  const StretchOptions so = discrete_options(state, 1);
  const auto rest = run_stretch(net, {0.0}, so);
  const double eval_s = network_eval_seconds(net);
  for (auto _ : state) {
    std::vector<StretchPoint> pts;
    const double s = seconds_of([&] {
      pts = run_stretch(net, {88.0}, so, {},
                        StretchState{{88.0}, {rest[0].x}, {rest[0].multipliers}});
    });
    set_sweep_counters(state, s, eval_s, pts[0].iterations, pts[0].converged,
                       net.topo.num_vertices);
  }
}

/// Discrete warm re-solve of the 13 forces after a 1 % persistence-length change; range(1) = 0
/// keeps the factorisation across forces in the warm run (StretchOptions::
/// refactorise_at_force_start = false), 1 refactorises at every force start (the default).
/// The cold run keeps the defaults.
void BM_DiscreteWarm(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Network& n0 = cached_network_p(n, 1.0);
  const Network& n1 = cached_network_p(n, 1.01);
  const StretchState before = stretch_state(run_stretch(n0, kMillsForces, StretchOptions{}));
  const double eval_s = network_eval_seconds(n1);
  const double cold_s = cold_seconds([&] { run_stretch(n1, kMillsForces, StretchOptions{}); });
  StretchOptions warm_options;
  warm_options.refactorise_at_force_start = state.range(1) != 0;
  for (auto _ : state) {
    std::vector<StretchPoint> pts;
    const double s =
        seconds_of([&] { pts = run_stretch(n1, kMillsForces, warm_options, {}, before); });
    int it = 0, fact = 0;
    bool ok = true;
    for (const auto& p : pts) it += p.iterations, fact += p.factorisations, ok = ok && p.converged;
    set_sweep_counters(state, s, eval_s, it, ok, n1.topo.num_vertices);
    state.counters["factorisations"] = fact;
    state.counters["cold_ratio"] = s / cold_s;
  }
}

/// The warm re-solve of BM_DiscreteWarm (default options) by a StretchSweepSolver: the cold
/// run at the old parameters (not timed) keeps each force's preconditioner, factorised at its
/// equilibrium; each warm force starts on its own instead of refactorising.
void BM_DiscreteWarmKept(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Network& n0 = cached_network_p(n, 1.0);
  const Network& n1 = cached_network_p(n, 1.01);
  const double eval_s = network_eval_seconds(n1);
  const double cold_s = cold_seconds([&] { run_stretch(n1, kMillsForces, StretchOptions{}); });
  for (auto _ : state) {
    StretchSweepSolver sweep;
    const StretchState before = stretch_state(sweep.run(n0, kMillsForces));
    std::vector<StretchPoint> pts;
    const double s = seconds_of([&] { pts = sweep.run(n1, kMillsForces, {}, before); });
    int it = 0, fact = 0;
    bool ok = true;
    for (const auto& p : pts) it += p.iterations, fact += p.factorisations, ok = ok && p.converged;
    set_sweep_counters(state, s, eval_s, it, ok, n1.topo.num_vertices);
    state.counters["factorisations"] = fact;
    state.counters["cold_ratio"] = s / cold_s;
  }
}

/// Continuum energy + gradient per vertex.
void BM_ContinuumEnergyGradient(benchmark::State& state) {
  const ContinuumModel& m = cached_continuum(static_cast<int>(state.range(0)));
  Positions g;
  for (auto _ : state) benchmark::DoNotOptimize(continuum_energy(m, m.rest, 88.0, &g));
  state.counters["vertices"] = static_cast<double>(m.rest.cols());
  state.counters["ns_per_vertex"] = benchmark::Counter(
      static_cast<double>(m.rest.cols()) * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

/// One continuum Newton Hessian assembly (add_lagrangian_hessian into the solver's lower
/// BlockHessian, after set_zero) at the 88 pN equilibrium, range(0) elements: the per-iteration
/// cost the Newton solve adds on top of its factorisation; also in energy+gradient evaluations.
void BM_ContinuumLagrangianHessian(benchmark::State& state) {
  const ContinuumModel& m = cached_continuum(static_cast<int>(state.range(0)));
  const auto pts = run_continuum_stretch(m, {88.0}, ContinuumOptions{});
  BlockHessian h(m.topo, BlockStorage::lower);
  const double la = pts[0].multipliers.area_pN_per_um, lv = pts[0].multipliers.volume_pN_per_um2;
  double total_s = 0.0;
  for (auto _ : state)
    total_s += seconds_of([&] {
      h.set_zero();
      add_lagrangian_hessian(m, pts[0].x, la, lv, h);
      benchmark::DoNotOptimize(h.matrix().valuePtr());
    });
  const double eval_s = continuum_eval_seconds(m);
  state.counters["eg_evals"] = total_s / static_cast<double>(state.iterations()) / eval_s;
  state.counters["vertices"] = static_cast<double>(m.rest.cols());
}

/// Canham-Helfrich on the Loop limit surface (continuum/loop_bending.hpp) on the rest mesh of
/// range(0) elements, interpolating control points: range(1) = 0 its energy and gradient (3-point
/// quadrature; the quadrature's set-up is not timed), 1 Juelicher's energy and gradient on the
/// same vertices for comparison.
void BM_LoopBending(benchmark::State& state) {
  const ContinuumModel& m = cached_continuum(static_cast<int>(state.range(0)));
  const std::vector<LoopQuadraturePoint> q = loop_quadrature(m.topo);
  const Positions c = loop_interpolating_control_points(m.topo, m.rest);
  Positions g(3, c.cols());
  for (auto _ : state) {
    g.setZero();
    if (state.range(1) == 1)
      benchmark::DoNotOptimize(juelicher_bending_energy(m.rest, m.topo, m.bending, &g));
    else
      benchmark::DoNotOptimize(loop_helfrich_energy(q, c, m.bending, &g));
  }
  state.counters["vertices"] = static_cast<double>(m.rest.cols());
  state.counters["quadrature_points"] = static_cast<double>(q.size());
}

/// The Loop element's 13-force sweep from rest (continuum/loop_stretch.hpp; full law, uniform
/// icosphere of range(0) elements with its vertices on the Evans-Fung surface; the model's
/// set-up is not timed), range(1) = 0 the full problem, 1 the mirror path (every symmetric
/// equilibrium checked). cost_units: the sweep's time over one energy-and-gradient evaluation of
/// the N = 1,002 network, the trade-off table's cost unit.
void BM_LoopSweep(benchmark::State& state) {
  const EvansFungShape shape;
  TriMesh mesh = make_continuum_mesh(static_cast<int>(state.range(0)), shape);
  for (int i = 0; i < mesh.x.cols(); ++i) mesh.x.col(i) = evans_fung_project(shape, mesh.x.col(i));
  const LoopContinuumModel m = build_loop_continuum_model(
      mesh, make_membrane_law(WlcParameters{}, StericParameters{}, WlcExpansion::full), {},
      rest_contact_plane(shape, 0.05));
  const double unit_s = network_eval_seconds(cached_network_p(1000, 1.0));
  for (auto _ : state) {
    std::vector<LoopStretchPoint> pts;
    LoopStretchOptions lo;
    lo.symmetry = state.range(1) == 1 ? Symmetry::mirror : Symmetry::none;
    const double s = seconds_of([&] { pts = run_loop_stretch(m, kMillsForces, lo); });
    int it = 0, factorisations = 0, checks = 0;
    bool ok = true;
    for (const auto& p : pts) {
      it += p.iterations;
      factorisations += p.factorisations;
      checks += p.stability_factorisations;
      ok = ok && p.status == NewtonStatus::converged;
    }
    set_sweep_counters(state, s, unit_s, it, ok, static_cast<int>(m.rest.cols()));
    state.counters["cost_units"] = s / unit_s;
    state.counters["factorisations"] = factorisations;
    state.counters["sector_factorisations"] = checks;
  }
}

/// The mirror path's stability check at the 88 pN equilibrium (range(0) elements, range(1)
/// symmetry argument as the sweep rows: 1 the default mesh, 2 the mirror-planes mesh): every
/// non-trivial sector assembled and factorised (NewtonSolver::check_symmetric_state); the
/// sectors' set-up (first call) is not timed. `sectors` counts the factorisations per check.
void BM_ContinuumStabilityCheck(benchmark::State& state) {
  const ContinuumModel& m =
      cached_continuum(static_cast<int>(state.range(0)), 1.0, bench_orientation(state, 1));
  const ContinuumOptions co = continuum_options(state, 1);
  const auto pts = run_continuum_stretch(m, {88.0}, co);
  NewtonSolver solver(m, co.newton);
  SectorStability st = solver.check_symmetric_state(88.0, pts[0].x, pts[0].multipliers);
  double total_s = 0.0;
  for (auto _ : state)
    total_s +=
        seconds_of([&] { st = solver.check_symmetric_state(88.0, pts[0].x, pts[0].multipliers); });
  if (!st.stable) state.SkipWithError("the 88 pN equilibrium is not stable");
  const double eval_s = continuum_eval_seconds(m);
  state.counters["eg_evals"] = total_s / static_cast<double>(state.iterations()) / eval_s;
  state.counters["sectors"] = st.factorisations;
  state.counters["vertices"] = static_cast<double>(m.rest.cols());
}

/// Metropolis sweeps at 300 K, zero force, from the rest shape, on state.range(1) OpenMP threads
/// (McOptions::threads: forced, where `rbc mc` takes mc_thread_decision's one thread below
/// kMcParallelVertices). Two RNG streams whatever the thread count, so both thread counts run
/// the SAME chain and the ratio of their rates is the parallel speed-up. 20 adaptive sweeps first
/// bring the acceptance to its 40 % target (the cost of a move does not depend much on it).
void BM_McSweep(benchmark::State& state) {
  const Network& net = cached_network(static_cast<int>(state.range(0)));
  const int threads = static_cast<int>(state.range(1));
  const int saved_threads = omp_get_max_threads();
  omp_set_num_threads(threads);
  McOptions o;
  o.temperature_K = 300.0;
  o.seed = 1;
  o.streams = 2;
  o.threads = threads;
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

/// Hamiltonian Monte Carlo trajectories (discrete/hmc_sampler.hpp, with HmcOptions' defaults:
/// area and volume as exact constraints) at 300 K, zero force, from the rest shape (the mass
/// matrix built there), on state.range(1) OpenMP threads (the energy and gradient's; the solves
/// run on one BLAS thread). 20 adaptive trajectories first bring the acceptance to its target.
/// Counters: energy + gradient evaluations and factor solves per trajectory, the mass matrix's
/// factor entries and build time, acceptance and step.
void BM_HmcTrajectory(benchmark::State& state) {
  const Network& net = cached_network(static_cast<int>(state.range(0)));
  const int threads = static_cast<int>(state.range(1));
  const int saved_threads = omp_get_max_threads();
  omp_set_num_threads(threads);
  McOptions o;
  o.algorithm = McAlgorithm::hmc;
  o.temperature_K = 300.0;
  o.seed = 1;
  o.adapt_sweeps = 20;
  LoadState load;
  load.stiffness_scale = 25.0;  // McRunSetup's default
  const auto t0 = std::chrono::steady_clock::now();
  HmcSampler hmc(net, load, net.rest, o);
  const double build_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (int s = 0; s < o.adapt_sweeps; ++s) hmc.sweep();
  const long long e0 = hmc.evaluations(), s0 = hmc.solves();
  long long trajectories = 0, accepted = 0;
  for (auto _ : state) {
    const McSweepStats st = hmc.sweep();
    ++trajectories;
    accepted += st.accepted;
  }
  omp_set_num_threads(saved_threads);
  const double n = double(std::max(1LL, trajectories));
  state.counters["vertices"] = net.topo.num_vertices;
  state.counters["threads"] = threads;
  state.counters["acceptance"] = double(accepted) / n;
  state.counters["step"] = hmc.step_um();
  state.counters["evals_per_traj"] = double(hmc.evaluations() - e0) / n;
  state.counters["solves_per_traj"] = double(hmc.solves() - s0) / n;
  state.counters["factor_entries"] = hmc.mass_info().factor_nonzeros;
  state.counters["mass_build_s"] = build_s;
}

/// A block of the two-chain Monte Carlo run (McRun, discrete/mc_run.hpp) of `rbc mc --sampler
/// hmc`: state.range(1) threads (1: the chains one after the other; 2: one chain per thread),
/// 300 K, zero force, from the rest shape; each iteration advances both chains by 4 trajectories
/// (one block). Both thread counts run the SAME chains, so the ratio of their rates is the
/// speed-up of the chains in parallel. 20 adaptive trajectories per chain first.
void BM_McChains(benchmark::State& state) {
  const Network& net = cached_network(static_cast<int>(state.range(0)));
  const int threads = static_cast<int>(state.range(1));
  McRunSetup setup;
  setup.sampler.algorithm = McAlgorithm::hmc;
  setup.sampler.temperature_K = 300.0;
  setup.sampler.seed = 1;
  setup.sampler.chains = 2;
  setup.sampler.threads = threads;  // the chains' threads
  setup.sampler.adapt_sweeps = 20;
  const int saved_threads = omp_get_max_threads();
  omp_set_num_threads(threads);
  McRun run(net, setup, net.rest);
  run.advance_blocks(setup.sampler.adapt_sweeps, setup.sampler.adapt_sweeps);
  constexpr long long kBlock = 4;
  long long chain_sweeps = 0;
  for (auto _ : state) {
    run.advance_blocks(run.sweeps_done() + kBlock, kBlock);
    chain_sweeps += kBlock * run.chain_count();
  }
  omp_set_num_threads(saved_threads);
  state.counters["vertices"] = net.topo.num_vertices;
  state.counters["threads"] = threads;
  state.counters["chains"] = run.chain_count();
  state.counters["chain_sweeps_per_s"] =
      benchmark::Counter(double(chain_sweeps), benchmark::Counter::kIsRate);
}

/// The console reporter plus closing tables of the Monte Carlo parallel speed-up: moves/s on
/// 2 threads over moves/s on 1 thread, per network size (from the mc/sweep runs), and the same
/// for the chain trajectories/s of the two-chain runs (mc/chains).
class SpeedupReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      const auto n = r.counters.find("vertices"), t = r.counters.find("threads"),
                 rate = r.counters.find("moves_per_s"),
                 chain_rate = r.counters.find("chain_sweeps_per_s");
      if (r.run_type != Run::RT_Iteration || n == r.counters.end() || t == r.counters.end())
        continue;
      if (rate != r.counters.end())
        rates_[static_cast<int>(n->second.value)][static_cast<int>(t->second.value)] =
            rate->second.value;
      if (chain_rate != r.counters.end())
        chain_rates_[static_cast<int>(n->second.value)][static_cast<int>(t->second.value)] =
            chain_rate->second.value;
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
    for (const auto& [n, by_threads] : chain_rates_) {
      const auto one = by_threads.find(1), two = by_threads.find(2);
      if (one == by_threads.end() || two == by_threads.end() || one->second <= 0) continue;
      std::cout << "Two HMC chains N = " << n << ": " << std::fixed << std::setprecision(2)
                << one->second << " trajectories/s on 1 thread, " << two->second
                << " on 2, speed-up " << two->second / one->second << "x\n";
    }
  }

 private:
  std::map<int, std::map<int, double>> rates_;        // vertices -> threads -> moves/s
  std::map<int, std::map<int, double>> chain_rates_;  // vertices -> threads -> trajectories/s
};

/// Throws std::invalid_argument if the parsed --benchmark_filter is no valid regular expression
/// or selects none of the benchmarks registered (Google Benchmark would print a line, run
/// nothing and let the command exit 0). Runs the listing of --benchmark_list_tests, which must
/// be set, into strings: nothing is printed or run.
void check_benchmark_filter(const std::string& suite, std::vector<std::string> families) {
  std::ostringstream listed, errors;
  benchmark::ConsoleReporter lister;
  lister.SetOutputStream(&listed);
  lister.SetErrorStream(&errors);
  if (benchmark::RunSpecifiedBenchmarks(&lister) > 0) return;
  const std::string filter = benchmark::GetBenchmarkFilter();
  const std::string why = errors.str();
  if (const auto at = why.find("Could not compile"); at != std::string::npos) {
    std::string reason =
        why.substr(why.find(": ", at) == std::string::npos ? at : why.find(": ", at) + 2);
    while (!reason.empty() && (reason.back() == '\n' || reason.back() == ' ')) reason.pop_back();
    throw std::invalid_argument("--benchmark_filter " + filter +
                                ": not a valid regular expression (" + reason + ")");
  }
  if (why.find("Failed to match") == std::string::npos) {
    std::string reason = why.empty() ? "Google Benchmark refused its options" : why;
    while (!reason.empty() && (reason.back() == '\n' || reason.back() == ' ')) reason.pop_back();
    throw std::invalid_argument("bench " + suite + ": " + reason);
  }
  std::sort(families.begin(), families.end());
  families.erase(std::unique(families.begin(), families.end()), families.end());
  std::string names;
  for (const auto& f : families) names += (names.empty() ? "" : ", ") + f;
  throw std::invalid_argument("--benchmark_filter " + filter +
                              ": matches no benchmark of `rbc bench " + suite +
                              "` (available: " + names + ")");
}

}  // namespace

void add_bench_command(CLI::App& app, Action& action) {
  auto args = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand(
      "bench",
      "Benchmarks: `rbc bench stretch` (discrete energy+gradient, one preconditioner solve in "
      "double and single precision, and time to equilibrium at 88 pN for N = 500, 2000, 8000, "
      "27500), `rbc bench mc` (Monte Carlo vertex moves/s "
      "on 1 and 2 threads, N = 500, 2000, 8000, and the parallel speed-up), `rbc bench infer` "
      "(the default calibration by TMCMC and by laplace-is, side by side), `rbc bench sweep` "
      "(force sweeps and warm re-solves, each also in energy+gradient "
      "evaluations, the continuum recovery row, and the Loop element's bending against "
      "Juelicher's); extra arguments go "
      "to Google Benchmark");
  cmd->allow_extras();
  cmd->prefix_command();
  cmd->callback([cmd, args, &action] {
    *args = cmd->remaining();
    action = [args]() -> int {
      std::string suite = args->empty() ? "stretch" : args->front();
      std::vector<std::string> families;  // the names registered, for the filter's message
      const auto reg = [&families](const char* name, auto* fn) {
        families.emplace_back(name);
        return benchmark::RegisterBenchmark(name, fn);
      };
      if (suite == "stretch") {
        reg("discrete/energy_gradient", BM_DiscreteEnergyGradient)
            ->Arg(500)
            ->Arg(2000)
            ->Arg(8000)
            ->Arg(27500)
            ->Unit(benchmark::kMicrosecond);
        reg("discrete/preconditioner_apply", BM_DiscretePreconditionerApply)
            ->Args({2000, 0})
            ->Args({2000, 1})
            ->Args({27500, 0})
            ->Args({27500, 1})
            ->Unit(benchmark::kMillisecond);
        reg("discrete/stretch_88pN", BM_DiscreteStretch88)
            ->Arg(500)
            ->Arg(2000)
            ->Arg(8000)
            ->Arg(27500)
            ->Unit(benchmark::kSecond)
            ->Iterations(1);
      } else if (suite == "sweep") {
        // The speed table's rows, one benchmark per row.
        const auto once = [](benchmark::internal::Benchmark* b) {
          return b->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
        };
        // Continuum rows: last argument 0 = the full problem, 1 = the mirror-symmetric states
        // (--symmetry mirror), 2 = the same on the mirror-planes mesh (--mesh-orientation
        // mirror-planes: another triangulation, all eight mirrors).
        once(reg("continuum/sweep13_from_rest", BM_ContinuumSweep)
                 ->Args({1000, 13, 0})
                 ->Args({1000, 13, 1})
                 ->Args({1000, 13, 2}));
        once(reg("continuum/88pN_from_0pN", BM_Continuum88From0)
                 ->Args({9680, 0})
                 ->Args({9680, 1})
                 ->Args({9680, 2}));
        once(reg("continuum/sweep8_from_rest", BM_ContinuumSweep)
                 ->Args({5120, 0, 0})
                 ->Args({5120, 0, 1})
                 ->Args({5120, 0, 2}));
        // Warm rows: third argument 1 = the symmetric equilibria checked at the highest force
        // only (--symmetry-check highest-force, the calibration's policy), 0 = at every force.
        once(reg("continuum/warm13_persistence_1pc", BM_ContinuumWarm)
                 ->Args({1000, 0, 0})
                 ->Args({1000, 1, 0})
                 ->Args({1000, 1, 1}));
        once(reg("continuum/warm13_persistence_1pc_kept", BM_ContinuumWarmKept)
                 ->Args({1000, 0, 0})
                 ->Args({1000, 1, 0})
                 ->Args({1000, 2, 0})
                 ->Args({1000, 1, 1})
                 ->Args({1000, 2, 1}));
        // 1 s of recovery at dt = 1 ms, continuum 1 % (target < 10 s on 2 cores).
        once(reg("continuum/recovery_1s_dt1ms", BM_ContinuumRecovery)->Args({1000, 1000}));
        // The Loop element's sweep (range(0) elements).
        once(reg("continuum/loop_sweep13_from_rest", BM_LoopSweep)
                 ->Args({500, 0})
                 ->Args({1000, 0})
                 ->Args({1000, 1})
                 ->Args({2000, 1}));
        // range(1): preconditioner threshold (-1: the default; 0: always; huge: never); last
        // argument, as the continuum rows: 0 = the full problem, 1 = --symmetry mirror.
        once(reg("discrete/sweep13_from_rest", BM_DiscreteSweep)
                 ->Args({250, -1, 0})
                 ->Args({250, -1, 1})
                 ->Args({250, 0, 0})
                 ->Args({250, 1 << 30, 0})
                 // The full spectrin level, 13 forces (target <= 60 s).
                 ->Args({27500, -1, 0})
                 ->Args({27500, -1, 1}));
        once(reg("discrete/warm13_persistence_1pc", BM_DiscreteWarm)
                 ->Args({250, 1})
                 ->Args({250, 0}));
        once(reg("discrete/warm13_persistence_1pc_kept", BM_DiscreteWarmKept)->Args({250}));
        once(reg("discrete/88pN_from_0pN", BM_Discrete88From0)->Args({27500, 0})->Args({27500, 1}));
        reg("continuum/energy_gradient", BM_ContinuumEnergyGradient)
            ->Arg(1000)
            ->Arg(9680)
            ->Unit(benchmark::kMicrosecond);
        reg("continuum/stability_check", BM_ContinuumStabilityCheck)
            ->Args({1000, 1})
            ->Args({1000, 2})
            ->Args({5120, 1})
            ->Args({5120, 2})
            ->Unit(benchmark::kMillisecond);
        reg("continuum/lagrangian_hessian", BM_ContinuumLagrangianHessian)
            ->Arg(1000)
            ->Arg(5120)
            ->Arg(9680)
            ->Unit(benchmark::kMillisecond);
        reg("continuum/loop_bending", BM_LoopBending)
            ->ArgNames({"elements", "mode"})
            ->ArgsProduct({{1000, 5120}, {0, 1}})
            ->Unit(benchmark::kMillisecond);
        reg("discrete/energy_gradient", BM_DiscreteEnergyGradient)
            ->Arg(250)
            ->Arg(27500)
            ->Unit(benchmark::kMicrosecond);
      } else if (suite == "mc") {
        reg("mc/sweep", BM_McSweep)
            ->ArgNames({"N", "threads"})
            ->ArgsProduct({{500, 2000, 8000}, {1, 2}})
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime()
            ->MinTime(2.0);
        reg("mc/hmc_trajectory", BM_HmcTrajectory)
            ->ArgNames({"N", "threads"})
            ->ArgsProduct({{500, 2000, 8000, 27500}, {1, 2}})
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime()
            ->MinTime(2.0);
        reg("mc/chains", BM_McChains)
            ->ArgNames({"N", "threads"})
            ->ArgsProduct({{8000}, {1, 2}})
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime()
            ->MinTime(2.0);
      } else if (suite == "infer") {
        register_infer_benchmarks(families);
      } else {
        throw std::invalid_argument(
            "bench " + suite + ": unknown benchmark suite (expected stretch, sweep, mc or infer)");
      }
      std::vector<std::string> rest(args->begin() + (args->empty() ? 0 : 1), args->end());
      // Google Benchmark's own flags only (--benchmark_filter=..., ...); anything else is refused
      // here, before any benchmark runs, with the one error format of every command.
      for (const auto& s : rest)
        if (s.rfind("--benchmark_", 0) != 0 && s.rfind("--v=", 0) != 0)
          throw std::invalid_argument("bench " + suite + " " + s +
                                      ": not a Google Benchmark option (expected "
                                      "--benchmark_...=VALUE, see --benchmark_list_tests)");
      // Its flags are parsed twice: first with --benchmark_list_tests, to check the filter without
      // running anything, then as given (a flag given twice takes its last value).
      // Google Benchmark keeps a pointer to argv[0] (the context block prints it): the flags of
      // both passes live until the benchmarks have run.
      std::array<std::vector<std::string>, 2> kept_flags;
      std::array<std::vector<char*>, 2> kept_argv;
      for (const bool listing : {true, false}) {
        std::vector<std::string>& flags = kept_flags[listing ? 0 : 1];
        flags = {"rbc"};  // its messages then start "rbc: "
        if (!listing) flags.emplace_back("--benchmark_list_tests=false");
        flags.insert(flags.end(), rest.begin(), rest.end());
        if (listing) {  // names only: no output file (its failure would exit silently)
          flags.emplace_back("--benchmark_list_tests=true");
          flags.emplace_back("--benchmark_out=");
        }
        std::vector<char*>& argv = kept_argv[listing ? 0 : 1];
        for (auto& f : flags) argv.push_back(f.data());
        int argc = static_cast<int>(argv.size());
        benchmark::Initialize(&argc, argv.data());
        if (benchmark::ReportUnrecognizedArguments(argc, argv.data())) return 2;
        if (listing) check_benchmark_filter(suite, families);
      }
      // The BLAS kernel in the context block (and in --benchmark_out=FILE.json's "context"): it
      // moves the factorisation rows by 14-25 % on the project's machines.
      const BlasInfo blas = blas_info();
      benchmark::AddCustomContext("blas",
                                  blas.library + (blas.core.empty() ? "" : " " + blas.core));
      // Whether AVX-512 kernels could run (OPENBLAS_CORETYPE=SkylakeX): these machines have
      // it and set Haswell (README, "Which OpenBLAS kernel runs").
#if defined(__x86_64__) && defined(__GNUC__)
      __builtin_cpu_init();
      benchmark::AddCustomContext("cpu_avx512f", __builtin_cpu_supports("avx512f") ? "yes" : "no");
#else
      benchmark::AddCustomContext("cpu_avx512f", "no");  // not an x86-64 CPU
#endif
      SpeedupReporter reporter;
      benchmark::RunSpecifiedBenchmarks(&reporter);
      benchmark::Shutdown();
      return 0;
    };
  });
}

}  // namespace rbc::app
