// SPDX-License-Identifier: GPL-3.0-or-later
#include "compare/methods.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "continuum/adapted_mesh.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/loop_stretch.hpp"
#include "continuum/refined_mesh.hpp"
#include "core/geometry.hpp"
#include "core/rest_shape.hpp"
#include "core/validation.hpp"
#include "discrete/stretch.hpp"
#include "homogenise/invariant_laws.hpp"

namespace rbc {

std::string Method::name() const {
  const std::string rotated = rotation_seed ? "_r" + std::to_string(rotation_seed) : "";
  if (kind == MethodKind::discrete) return "discrete_N" + std::to_string(resolution) + rotated;
  if (adapted || refined) {
    char ratio[32];
    std::snprintf(ratio, sizeof ratio, "%g", size_ratio);
    return std::string(adapted ? "continuum_adapted" : "continuum_refined") + ratio + "_p" +
           to_string(order) + "_E" + std::to_string(resolution) + rotated;
  }
  if (loop)
    return "continuum_loop_p" + to_string(order) + "_E" + std::to_string(resolution) + rotated;
  return "continuum_p" + to_string(order) + "_E" + std::to_string(resolution) + rotated;
}

std::string Method::label() const {
  if (kind == MethodKind::discrete)
    return "microscopic model (N = " + std::to_string(resolution) + ")";
  if (adapted || refined) {
    std::ostringstream ratio;
    ratio << size_ratio;
    return "continuum p = " + to_string(order) + " (" + std::to_string(resolution) + " elements, " +
           (adapted ? "adapted" : "refined") + " mesh, ratio " + ratio.str() + ")";
  }
  if (loop)
    return "continuum p = " + to_string(order) + " (" + std::to_string(resolution) +
           " Loop elements)";
  return "continuum p = " + to_string(order) + " (" + std::to_string(resolution) + " elements)";
}

Method parse_method(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  for (std::string p; std::getline(ss, p, ':');) parts.push_back(p);
  auto number = [&](const std::string& s) {
    const std::optional<long long> v = parse_integer(s);
    if (!v || *v <= 0 || *v > std::numeric_limits<int>::max())
      throw std::invalid_argument("method '" + text + "': '" + s + "' is not a positive count");
    return static_cast<int>(*v);
  };
  Method m;
  if (parts.size() == 2 && parts[0] == "discrete") {
    m.kind = MethodKind::discrete;
    m.resolution = number(parts[1]);
    return m;
  }
  if (parts.size() == 3 && parts[0] == "continuum") {
    m.kind = MethodKind::continuum;
    m.order = wlc_expansion_from_string(parts[1]);
    m.resolution = number(parts[2]);
    return m;
  }
  if (((parts.size() == 3 || parts.size() == 4) &&
       (parts[0] == "continuum-adapted" || parts[0] == "continuum-refined")) ||
      (parts.size() == 3 && parts[0] == "continuum-loop")) {
    m.kind = MethodKind::continuum;
    m.adapted = parts[0] == "continuum-adapted";
    m.refined = parts[0] == "continuum-refined";
    m.loop = parts[0] == "continuum-loop";
    try {
      m.order = wlc_expansion_from_string(parts[1]);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("method '" + text + "': " + e.what());
    }
    m.resolution = number(parts[2]);
    if (m.resolution < kMinContinuumElements || m.resolution > kMaxContinuumElements)
      throw std::invalid_argument("method '" + text + "': elements must be in [" +
                                  std::to_string(kMinContinuumElements) + ", " +
                                  std::to_string(kMaxContinuumElements) + "]");
    if (parts.size() == 4) {
      const std::optional<double> r = parse_finite_number(parts[3]);
      if (!r || *r < 1 || *r > 10)
        throw std::invalid_argument("method '" + text + "': size ratio '" + parts[3] +
                                    "' is not a number in [1, 10]");
      m.size_ratio = *r;
    }
    return m;
  }
  throw std::invalid_argument("method '" + text +
                              "' is not of the form discrete:N, continuum:ORDER:ELEMENTS, "
                              "continuum-adapted:ORDER:ELEMENTS[:RATIO], "
                              "continuum-refined:ORDER:ELEMENTS[:RATIO] or "
                              "continuum-loop:ORDER:ELEMENTS");
}

bool MethodRun::all_converged() const {
  for (const auto& p : points)
    if (!p.converged) return false;
  return true;
}

Network make_discrete_network(int vertices) {
  return make_discrete_network(vertices, 0);
}

Network make_discrete_network(int vertices, unsigned rotation_seed) {
  return make_discrete_network(vertices, rotation_seed, NetworkParameters{});
}

Network make_discrete_network(int vertices, unsigned rotation_seed,
                              const NetworkParameters& parameters) {
  RestShapeOptions ro;
  ro.target_vertices = vertices;
  ro.rotation_seed = rotation_seed;
  return build_network(make_rest_shape(ro), parameters);
}

double evaluation_cpu_seconds(const std::function<void()>& eval) {
  std::vector<double> t;
  for (int b = 0; b < 7; ++b) {
    int reps = 0;
    const double t0 = process_cpu_seconds();
    double used = 0;
    do {
      eval();
      ++reps;
      used = process_cpu_seconds() - t0;
    } while (used < 0.02);
    t.push_back(used / reps);
  }
  std::sort(t.begin(), t.end());
  return t[3];
}

double network_evaluation_cpu_seconds(const Network& net) {
  Positions g;
  LoadState load;
  load.force_pN = 88.0;
  // The gradient is written through a pointer in another translation unit: not elided.
  return evaluation_cpu_seconds([&] { network_energy(net, net.rest, load, &g); });
}

namespace {

using Clock = std::chrono::steady_clock;

/// Copies a model's equilibria into the common curve and stamps the total time.
template <class Point>
void finish_run(MethodRun& run, const std::vector<Point>& pts, Clock::time_point t0, double cpu0) {
  run.cpu_s = process_cpu_seconds() - cpu0;
  for (const auto& p : pts)
    run.points.push_back({p.force_pN, p.axial_um, p.transverse_um, p.wall_s, p.residual_pN,
                          p.iterations, p.converged});
  run.total_s = std::chrono::duration<double>(Clock::now() - t0).count();
}

MethodRun run_discrete(const Method& m, const std::vector<double>& forces,
                       const ProgressSink& progress, const RunMethodOptions& ro) {
  const auto t0 = std::chrono::steady_clock::now();
  MethodRun run;
  run.method = m;
  run.symmetry = ro.symmetry;
  const Network net = make_discrete_network(m.resolution, m.rotation_seed, ro.parameters);
  run.vertices = net.topo.num_vertices;
  run.elements = net.topo.num_faces();
  run.patch_plus_um2 = net.patch.area_plus_um2;
  run.patch_minus_um2 = net.patch.area_minus_um2;
  run.surface_um2 = total_area(net.rest, net.topo);
  if (ro.measure_evaluation) run.eval_cpu_s = network_evaluation_cpu_seconds(net);
  run.setup_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu0 = process_cpu_seconds();
  StretchOptions so;
  so.symmetry = ro.symmetry;
  if (ro.discrete_force_tolerance_pN > 0)
    so.minimiser.force_tolerance = ro.discrete_force_tolerance_pN;
  const auto pts = run_stretch(net, forces, so, [&](const std::string& msg) {
    if (msg.rfind("F = ", 0) == 0) report(progress, m.name() + ": " + msg);
  });
  finish_run(run, pts, t0, cpu0);
  return run;
}

MethodRun run_loop(const Method& m, const std::vector<double>& forces, const ProgressSink& progress,
                   const RunMethodOptions& ro) {
  const auto t0 = std::chrono::steady_clock::now();
  MethodRun run;
  run.method = m;
  run.symmetry = ro.symmetry;
  const NetworkParameters& p = ro.parameters;
  const EvansFungShape shape;
  TriMesh mesh = make_continuum_mesh(m.resolution, m.rotation_seed);
  for (int i = 0; i < mesh.x.cols(); ++i) mesh.x.col(i) = evans_fung_project(shape, mesh.x.col(i));
  const LoopContinuumModel model =
      build_loop_continuum_model(mesh, make_membrane_law(p.wlc, p.steric, m.order), p.bending,
                                 rest_contact_plane(shape, p.tweezers.contact_fraction));
  run.vertices = model.topo.num_vertices;
  run.elements = model.topo.num_faces();
  run.patch_plus_um2 = model.cap_right_um2;
  run.patch_minus_um2 = model.cap_left_um2;
  run.surface_um2 = model.area0_um2;
  if (ro.measure_evaluation) {
    Positions g;
    run.eval_cpu_s =
        evaluation_cpu_seconds([&] { loop_continuum_energy(model, model.rest, 88.0, &g); });
  }
  run.setup_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu0 = process_cpu_seconds();
  LoopStretchOptions lo;
  lo.symmetry = ro.symmetry;
  const auto pts = run_loop_stretch(model, forces, lo, [&](const std::string& msg) {
    if (msg.rfind("F = ", 0) == 0) report(progress, m.name() + ": " + msg);
  });
  run.cpu_s = process_cpu_seconds() - cpu0;
  for (const LoopStretchPoint& pt : pts)
    run.points.push_back({pt.force_pN, pt.diameters.axial_um, pt.diameters.transverse_um, pt.wall_s,
                          pt.residual_pN, pt.iterations, pt.status == NewtonStatus::converged});
  run.total_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return run;
}

MethodRun run_continuum(const Method& m, const std::vector<double>& forces,
                        const ProgressSink& progress, const RunMethodOptions& ro) {
  if (m.loop) return run_loop(m, forces, progress, ro);
  const auto t0 = std::chrono::steady_clock::now();
  MethodRun run;
  run.method = m;
  run.symmetry = ro.symmetry;
  const NetworkParameters& p = ro.parameters;
  TriMesh mesh;
  if (m.adapted) {
    AdaptedMeshOptions ao;
    ao.target_elements = m.resolution;
    ao.size_ratio = m.size_ratio;
    ao.seed = m.rotation_seed;
    ao.contact_fraction = p.tweezers.contact_fraction;
    ao.validate();
    mesh = make_adapted_mesh(ao);
  } else if (m.refined) {
    RefinedMeshOptions ro;
    ro.target_elements = m.resolution;
    ro.size_ratio = m.size_ratio;
    ro.seed = m.rotation_seed;
    ro.contact_fraction = p.tweezers.contact_fraction;
    ro.validate();
    mesh = make_refined_mesh(ro);
  } else {
    mesh = make_continuum_mesh(m.resolution, m.rotation_seed);
  }
  // The same spectrin, bending and contact parameters as the discrete model.
  const IsotropicMembraneLaw law = make_membrane_law(p.wlc, p.steric, m.order);
  ContinuumParameters cp;
  cp.bending = p.bending;
  cp.tweezers = p.tweezers;
  const ContinuumModel model = build_continuum_model(mesh, law, cp);
  run.vertices = model.topo.num_vertices;
  run.elements = model.num_elements();
  run.patch_plus_um2 = model.patch.area_plus_um2;
  run.patch_minus_um2 = model.patch.area_minus_um2;
  run.surface_um2 = total_area(model.rest, model.topo);
  if (ro.measure_evaluation) {
    Positions g;
    run.eval_cpu_s = evaluation_cpu_seconds([&] { continuum_energy(model, model.rest, 88.0, &g); });
  }
  run.setup_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu0 = process_cpu_seconds();
  ContinuumOptions co;
  co.newton.symmetry = ro.symmetry;
  if (m.adapted || m.refined) {  // the load and the measure that do not snap to the mesh
    co.load = ContinuumLoad::exact_contact;
    co.exact_contact_fraction = p.tweezers.contact_fraction;
    co.measure = ContinuumMeasure::quadric_fit;
  }
  const auto pts = run_continuum_stretch(model, forces, co, [&](const std::string& msg) {
    if (msg.rfind("F = ", 0) == 0) report(progress, m.name() + ": " + msg);
  });
  finish_run(run, pts, t0, cpu0);
  return run;
}

}  // namespace

MethodRun run_method(const Method& m, const std::vector<double>& forces,
                     const ProgressSink& progress) {
  return run_method(m, forces, progress, RunMethodOptions{});
}

MethodRun run_method(const Method& m, const std::vector<double>& forces,
                     const ProgressSink& progress, const RunMethodOptions& options) {
  return m.kind == MethodKind::discrete ? run_discrete(m, forces, progress, options)
                                        : run_continuum(m, forces, progress, options);
}

}  // namespace rbc
