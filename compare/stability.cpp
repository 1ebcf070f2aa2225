// SPDX-License-Identifier: GPL-3.0-or-later
#include "compare/stability.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "compare/plot.hpp"
#include "continuum/continuum_stretch.hpp"
#include "core/geometry.hpp"
#include "core/io.hpp"
#include "core/rest_shape.hpp"
#include "discrete/mc_run.hpp"
#include "discrete/stretch.hpp"
#include "homogenise/invariant_laws.hpp"
#include "homogenise/moduli.hpp"

namespace rbc {
namespace {

/// Largest principal stretch of an element from its invariants:
/// lambda_max^2 = 1 + I2/2 + sqrt(I2^2 + 4 I2 - 4 I1^2 - 8 I1)/2 (paper Appendix A).
double largest_stretch(double i1, double i2) {
  const double disc = std::max(0.0, i2 * i2 + 4 * i2 - 4 * i1 * i1 - 8 * i1);
  return std::sqrt(1.0 + 0.5 * i2 + 0.5 * std::sqrt(disc));
}

// Relative departure of D_A(order) from D_A(full) along the ladder; returns the first force
// (linearly interpolated) where it exceeds `tolerance`, or nothing if it never does.
std::optional<double> departure_force(const OrderCurve& c, const OrderCurve& full,
                                      double tolerance) {
  double prev_f = 0, prev_dev = 0;
  for (size_t k = 0; k < c.force_pN.size() && k < full.force_pN.size(); ++k) {
    if (!c.converged[k] || !full.converged[k]) break;
    const double dev = std::abs(c.axial_um[k] / full.axial_um[k] - 1.0);
    if (dev > tolerance) {
      if (k == 0) return c.force_pN[k];
      return prev_f + (tolerance - prev_dev) / (dev - prev_dev) * (c.force_pN[k] - prev_f);
    }
    prev_f = c.force_pN[k];
    prev_dev = dev;
  }
  return std::nullopt;
}

void order_sweep(const StabilityOptions& o, StabilityResult& res, const ProgressSink& progress) {
  const TriMesh mesh = make_continuum_mesh(o.continuum_elements);
  const NetworkParameters defaults;
  const double x0 = defaults.wlc.lbar_um / defaults.wlc.lmax_um;
  for (auto order :
       {WlcExpansion::full, WlcExpansion::order2, WlcExpansion::order3, WlcExpansion::order4}) {
    report(progress, "stability: continuum order " + to_string(order) + " up to " +
                         std::to_string(o.order_forces_pN.back()) + " pN");
    const ContinuumModel model = build_continuum_model(
        mesh, make_membrane_law(defaults.wlc, defaults.steric, order), ContinuumParameters{});
    ContinuumOptions co;
    co.max_bisections = o.continuum_bisections;
    co.beyond_documented_force_range = true;  // the ladder runs past the documented maximum
    const auto pts = run_continuum_stretch(model, o.order_forces_pN, co);
    OrderCurve c;
    c.order = to_string(order);
    for (const auto& p : pts) {
      c.force_pN.push_back(p.force_pN);
      c.axial_um.push_back(p.axial_um);
      c.transverse_um.push_back(p.transverse_um);
      c.converged.push_back(p.converged);
      double s = 0;
      for (Eigen::Index e = 0; e < p.fields.i1.size(); ++e)
        s = std::max(s, largest_stretch(p.fields.i1(e), p.fields.i2(e)));
      c.max_link_stretch.push_back(s * x0);  // L/Lmax of the most stretched link direction
    }
    res.orders.push_back(std::move(c));
  }
  const OrderCurve& full = res.orders.front();
  for (size_t k = 1; k < res.orders.size(); ++k) {
    const OrderCurve& c = res.orders[k];
    const std::string method = "continuum p=" + c.order;
    for (double tol : {0.01, 0.05})
      res.rows.push_back({StabilityStudy::taylor_order, method, "tolerance", tol,
                          StabilityMetric::departure_force_pN, departure_force(c, full, tol),
                          "first force where D_A departs from the full WLC law by this fraction"});
    // Unphysical: a link direction stretched beyond the contour length (L > Lmax), which
    // the full WLC forbids, or a non-converged solve.
    std::optional<double> unphysical;
    for (size_t i = 0; i < c.force_pN.size(); ++i)
      if (!c.converged[i] || c.max_link_stretch[i] >= 1.0) {
        unphysical = c.force_pN[i];
        break;
      }
    res.rows.push_back({StabilityStudy::taylor_order, method, "", 0,
                        StabilityMetric::unphysical_from_force_pN, unphysical,
                        "first ladder force with a link direction past Lmax (L/Lmax >= 1) or "
                        "no convergence"});
  }
  for (const auto& c : res.orders)
    res.rows.push_back({StabilityStudy::taylor_order, "continuum p=" + c.order, "force_pN",
                        c.force_pN.back(), StabilityMetric::max_link_stretch_L_over_Lmax,
                        c.max_link_stretch.back(),
                        "largest L/Lmax over element directions at the top force"});
}

void budget_sweep(const StabilityOptions& o, StabilityResult& res, const ProgressSink& progress) {
  const Network net = make_discrete_network(std::min(o.discrete_vertices, 500));
  StretchOptions so;
  so.minimiser.max_iterations = o.discrete_iteration_budget;
  so.beyond_documented_force_range = true;  // the ladder runs past the documented maximum
  report(progress, "stability: discrete solver budget up to " +
                       std::to_string(o.budget_forces_pN.back()) + " pN");
  const auto pts = run_stretch(net, o.budget_forces_pN, so);
  const std::string method = "discrete N=" + std::to_string(net.topo.num_vertices);
  for (const auto& p : pts) {
    res.rows.push_back({StabilityStudy::solver_budget, method, "force_pN", p.force_pN,
                        StabilityMetric::converged, p.converged ? 1.0 : 0.0, to_string(p.status)});
    res.rows.push_back({StabilityStudy::solver_budget, method, "force_pN", p.force_pN,
                        StabilityMetric::iterations, static_cast<double>(p.iterations),
                        "L-BFGS iterations"});
  }
  if (!o.include_continuum) return;
  const TriMesh mesh = make_continuum_mesh(o.continuum_elements);
  const NetworkParameters defaults;
  for (auto order : {WlcExpansion::order2, WlcExpansion::full}) {
    report(progress, "stability: continuum p=" + to_string(order) + " solver budget");
    const ContinuumModel model = build_continuum_model(
        mesh, make_membrane_law(defaults.wlc, defaults.steric, order), ContinuumParameters{});
    ContinuumOptions co;
    co.max_bisections = o.continuum_bisections;
    co.beyond_documented_force_range = true;
    const auto cp = run_continuum_stretch(model, o.budget_forces_pN, co);
    for (const auto& p : cp) {
      const std::string m = "continuum p=" + to_string(order);
      res.rows.push_back({StabilityStudy::solver_budget, m, "force_pN", p.force_pN,
                          StabilityMetric::converged, p.converged ? 1.0 : 0.0,
                          to_string(p.status)});
      res.rows.push_back({StabilityStudy::solver_budget, m, "force_pN", p.force_pN,
                          StabilityMetric::iterations, static_cast<double>(p.iterations),
                          "Newton iterations (all sub-steps)"});
    }
  }
}

void mesh_quality_sweep(const StabilityOptions& o, StabilityResult& res,
                        const ProgressSink& progress) {
  for (auto q :
       {RestMeshQuality::phi_minimised, RestMeshQuality::projected, RestMeshQuality::equal_area}) {
    report(progress, "stability: discrete network quality " + to_string(q));
    RestShapeOptions ro;
    ro.target_vertices = o.discrete_vertices;
    ro.quality = q;
    MeshQualityReport mr;
    const Network net = build_network(make_rest_shape(ro, &mr), NetworkParameters{});
    const Diameters rest = measure_diameters(net.rest);
    const auto pts = run_stretch(net, {0.0, 88.0}, StretchOptions{});
    const std::string method = "discrete " + to_string(q);
    res.rows.push_back({StabilityStudy::mesh_quality, method, "phi_over_area", mr.phi_over_area,
                        StabilityMetric::zero_force_axial_change,
                        pts[0].axial_um / rest.axial_um - 1.0,
                        "relative D_A change in the zero-force relaxation"});
    res.rows.push_back({StabilityStudy::mesh_quality, method, "phi_over_area", mr.phi_over_area,
                        StabilityMetric::axial_um_at_88pN, pts[1].axial_um,
                        to_string(pts[1].status)});
    res.rows.push_back({StabilityStudy::mesh_quality, method, "phi_over_area", mr.phi_over_area,
                        StabilityMetric::largest_rest_inplane_force_pN,
                        largest_rest_inplane_force_pN(net), ""});
  }
}

void steric_sweep(const StabilityOptions& o, StabilityResult& res, const ProgressSink& progress) {
  RestShapeOptions ro;
  ro.target_vertices = o.discrete_vertices;
  const TriMesh mesh = make_rest_shape(ro);
  for (double q : o.qs)
    for (double eta : o.etas) {
      std::ostringstream m;
      m << "discrete q=" << q << " eta=" << eta;
      report(progress, "stability: " + m.str());
      NetworkParameters p;
      p.steric.q = q;
      p.steric.eta = eta;
      const LinearModuli lm = closed_form_moduli(p.wlc, p.steric);
      const Network net = build_network(mesh, p);
      const auto pts = run_stretch(net, {0.0, o.steric_force_pN}, StretchOptions{});
      res.rows.push_back({StabilityStudy::steric, m.str(), "eta", eta,
                          StabilityMetric::K_closed_pN_per_um, lm.K_pN_per_um, ""});
      res.rows.push_back(
          {StabilityStudy::steric, m.str(), "eta", eta, StabilityMetric::axial_um_at_force,
           pts.back().axial_um,
           to_string(pts.back().status) + " at " + std::to_string(o.steric_force_pN) + " pN"});
      res.rows.push_back({StabilityStudy::steric, m.str(), "eta", eta,
                          StabilityMetric::transverse_um_at_force, pts.back().transverse_um, ""});
    }
}

// Monte Carlo limits: acceptance and decorrelation against the trial step at 300 K, and
// against temperature with the adaptive step (where the penalties stop holding area/volume).
void monte_carlo_sweep(const StabilityOptions& o, StabilityResult& res,
                       const ProgressSink& progress) {
  const Network net = make_discrete_network(o.mc_vertices);
  Positions x0 = net.rest;
  ConstraintMultipliers lambda;
  const StretchPoint eq = solve_equilibrium(net, 0.0, x0, lambda, StretchOptions{});
  const std::string method = "monte carlo N=" + std::to_string(net.topo.num_vertices);
  auto run = [&](double temperature, double step, int adapt) {
    McRunSetup setup;
    setup.sampler.temperature_K = temperature;
    setup.sampler.initial_step_um = step;
    setup.sampler.adapt_sweeps = adapt;
    setup.sampler.seed = 7;
    setup.multipliers = lambda;
    setup.reference_axial_um = eq.axial_um;
    setup.reference_transverse_um = eq.transverse_um;
    McRun mc(net, setup, x0);
    mc.advance(adapt + o.mc_sweeps);
    return mc.summarise();
  };
  for (double step : o.mc_steps_um) {
    report(progress, "stability: Monte Carlo step " + std::to_string(step) + " um at 300 K");
    const McSummary s = run(300.0, step, 0);
    res.rows.push_back({StabilityStudy::monte_carlo, method, "step_um", step,
                        StabilityMetric::acceptance, s.acceptance, "fixed step, 300 K, 0 pN"});
    res.rows.push_back({StabilityStudy::monte_carlo, method, "step_um", step,
                        StabilityMetric::energy_inefficiency, s.energy.inefficiency,
                        "statistical inefficiency g of the energy series (sweeps per independent "
                        "sample); large g = slow decorrelation"});
  }
  for (double t : o.mc_temperatures_K) {
    report(progress, "stability: Monte Carlo at " + std::to_string(t) + " K");
    const McSummary s = run(t, 0.0, o.mc_sweeps / 2);
    res.rows.push_back({StabilityStudy::monte_carlo, method, "temperature_K", t,
                        StabilityMetric::axial_shift_um, s.axial.mean - eq.axial_um,
                        "mean D_A minus the zero-temperature D_A"});
    res.rows.push_back({StabilityStudy::monte_carlo, method, "temperature_K", t,
                        StabilityMetric::axial_std_um, std::sqrt(s.axial.variance),
                        "thermal fluctuation of D_A"});
    res.rows.push_back({StabilityStudy::monte_carlo, method, "temperature_K", t,
                        StabilityMetric::max_area_drift, s.max_area_drift,
                        "largest |A - A0|/A0 sampled: above 1e-4 the penalties no longer hold "
                        "the bilayer area (MODEL.md)"});
    res.rows.push_back({StabilityStudy::monte_carlo, method, "temperature_K", t,
                        StabilityMetric::acceptance, s.acceptance, "adaptive step"});
  }
}

}  // namespace

std::string to_string(StabilityStudy s) {
  switch (s) {
    case StabilityStudy::taylor_order:
      return "taylor_order";
    case StabilityStudy::solver_budget:
      return "solver_budget";
    case StabilityStudy::mesh_quality:
      return "mesh_quality";
    case StabilityStudy::steric:
      return "steric";
    case StabilityStudy::monte_carlo:
      return "monte_carlo";
    case StabilityStudy::resolution:
      return "resolution";
  }
  return "unknown";
}

std::string to_string(StabilityMetric m) {
  switch (m) {
    case StabilityMetric::departure_force_pN:
      return "departure_force_pN";
    case StabilityMetric::unphysical_from_force_pN:
      return "unphysical_from_force_pN";
    case StabilityMetric::max_link_stretch_L_over_Lmax:
      return "max_link_stretch_L_over_Lmax";
    case StabilityMetric::converged:
      return "converged";
    case StabilityMetric::iterations:
      return "iterations";
    case StabilityMetric::zero_force_axial_change:
      return "zero_force_axial_change";
    case StabilityMetric::axial_um_at_88pN:
      return "axial_um_at_88pN";
    case StabilityMetric::largest_rest_inplane_force_pN:
      return "largest_rest_inplane_force_pN";
    case StabilityMetric::K_closed_pN_per_um:
      return "K_closed_pN_per_um";
    case StabilityMetric::axial_um_at_force:
      return "axial_um_at_force";
    case StabilityMetric::transverse_um_at_force:
      return "transverse_um_at_force";
    case StabilityMetric::acceptance:
      return "acceptance";
    case StabilityMetric::energy_inefficiency:
      return "energy_inefficiency";
    case StabilityMetric::axial_shift_um:
      return "axial_shift_um";
    case StabilityMetric::axial_std_um:
      return "axial_std_um";
    case StabilityMetric::max_area_drift:
      return "max_area_drift";
    case StabilityMetric::coarsest_resolution:
      return "coarsest_resolution";
  }
  return "unknown";
}

void add_resolution_rows(const TradeoffResult& t, double tol, std::vector<StabilityRow>& rows) {
  std::map<std::string, const TradeoffRow*> coarsest;
  for (const auto& r : t.rows) {
    if (!r.converged || r.axial_error_um > tol * t.reference.axial_um) continue;
    const std::string family = r.run.method.kind == MethodKind::discrete
                                   ? "discrete"
                                   : "continuum p=" + to_string(r.run.method.order);
    auto it = coarsest.find(family);
    if (it == coarsest.end() || r.run.method.resolution < it->second->run.method.resolution)
      coarsest[family] = &r;
  }
  for (const auto& [family, r] : coarsest)
    rows.push_back(
        {StabilityStudy::resolution, family, "tolerance", tol, StabilityMetric::coarsest_resolution,
         static_cast<double>(r->run.method.resolution),
         "vertices (discrete) or elements (continuum) within the tolerance of the "
         "reference D_A at " +
             std::to_string(t.force_pN) + " pN; wall " + std::to_string(r->wall_s) + " s"});
}

StabilityResult run_stability(const StabilityOptions& o, const TradeoffResult* tradeoff,
                              const ProgressSink& progress) {
  StabilityResult res;
  if (o.include_continuum) order_sweep(o, res, progress);
  budget_sweep(o, res, progress);
  mesh_quality_sweep(o, res, progress);
  steric_sweep(o, res, progress);
  if (o.include_monte_carlo) monte_carlo_sweep(o, res, progress);
  if (tradeoff)
    for (double tol : {0.01, 0.05}) add_resolution_rows(*tradeoff, tol, res.rows);
  return res;
}

void write_stability(const StabilityResult& r, const std::string& dir) {
  ensure_output_directory(dir);
  std::ostringstream csv;
  csv << "# where each method stops working (rbc stability); value 'not reached': the sweep "
         "did not reach what the metric looks for\n"
      << "study,method,parameter,parameter_value,metric,value,note\n";
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& row : r.rows) {
    const bool reached = row.value && std::isfinite(*row.value);
    csv << to_string(row.study) << "," << row.method << "," << row.parameter << ","
        << row.parameter_value << "," << to_string(row.metric) << ",";
    if (reached)
      csv << *row.value;
    else
      csv << "not reached";
    csv << ",\"" << row.note << "\"\n";
    nlohmann::json j = {{"study", to_string(row.study)},
                        {"method", row.method},
                        {"parameter", row.parameter},
                        {"parameter_value", row.parameter_value},
                        {"metric", to_string(row.metric)},
                        {"reached", reached},
                        {"note", row.note}};
    if (reached) j["value"] = *row.value;
    rows.push_back(std::move(j));
  }
  write_text_atomic(dir + "/stability.csv", csv.str());
  write_text_atomic(dir + "/stability.json", rows.dump(2) + "\n");
  if (r.orders.empty()) return;
  PlotSpec spec;
  spec.title = "Taylor orders against the full WLC law (continuum model)";
  spec.xlabel = "total stretching force F (pN)";
  spec.ylabel = "diameter (µm)";
  spec.key = "outside right top";
  static const char* colors[] = {"#000000", "#1f77b4", "#2ca02c", "#ff7f0e"};
  for (size_t k = 0; k < r.orders.size(); ++k) {
    const auto& c = r.orders[k];
    CsvTable t;
    t.comments = {"continuum order " + c.order + "; max_link_stretch = largest L/Lmax"};
    t.header = {"force_pN", "axial_um", "transverse_um", "max_link_stretch", "converged"};
    for (size_t i = 0; i < c.force_pN.size(); ++i)
      t.rows.push_back({c.force_pN[i], c.axial_um[i], c.transverse_um[i], c.max_link_stretch[i],
                        c.converged[i] ? 1.0 : 0.0});
    const std::string file = "stability_order_" + c.order + ".csv";
    write_csv(dir + "/" + file, t);
    const std::string title = c.order == "full" ? "full WLC" : "p = " + c.order;
    spec.series.push_back({title + " D_{A}", file, "1:2", "linespoints", colors[k % 4], 7, 1});
    spec.series.push_back({title + " D_{T}", file, "1:3", "linespoints", colors[k % 4], 5, 2});
  }
  render_plot(spec, dir, "stability_orders");
}

}  // namespace rbc
