// SPDX-License-Identifier: GPL-3.0-or-later
#include "compare/mc_convergence.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "compare/methods.hpp"
#include "compare/plot.hpp"
#include "core/geometry.hpp"
#include "core/io.hpp"
#include "core/validation.hpp"
#include "discrete/mc_sampler.hpp"
#include "discrete/stretch.hpp"

namespace rbc {

void McConvergenceOptions::validate() const {
  require_integer_in_range("Monte Carlo study vertices", vertices, 100, 40000);
  validate_discrete_force(force_pN);
  require_finite_in_range("Monte Carlo budget", "s", mc_budget_s, 0.0, kMaxMcBudget_s);
  require_finite_in_range("Monte Carlo temperature", "K", mc_temperature_K, 0.0, kMaxTemperature_K,
                          Ends::closed_closed);
  // At T = 0 only downhill moves are accepted: acceptance cannot exceed 1/2 (see the field).
  if (mc_temperature_K == 0)
    require_finite_in_range("Monte Carlo target acceptance at 0 K", "", mc_target_acceptance, 0.0,
                            0.5, Ends::open_open);
  else
    require_finite_in_range("Monte Carlo target acceptance", "", mc_target_acceptance, 0.0, 1.0,
                            Ends::open_open);
  require_integer_in_range("Monte Carlo sample interval (sweeps; 0 = log-spaced)",
                           sample_every_sweeps, 0, std::numeric_limits<int>::max());
  require_integer_in_range("Monte Carlo sweep count (0 = budget)", mc_sweeps, 0,
                           std::numeric_limits<int>::max());
  if (force_tolerances_pN.empty())
    throw std::invalid_argument("minimiser force tolerances: expected at least one, got none");
  for (double t : force_tolerances_pN)
    require_finite_in_range("minimiser force tolerance", "pN", t, 0.0, kMaxForceTolerance_pN);
  if (relative_accuracies.empty())
    throw std::invalid_argument("accuracy levels: expected at least one, got none");
  for (double a : relative_accuracies)
    require_finite_in_range("accuracy level (fraction of D_A)", "", a, 0.0, 1.0);
}

std::optional<double> TimeToAccuracy::ratio() const {
  if (!minimiser_s || !mc_s || !(*minimiser_s > 0)) return std::nullopt;
  return *mc_s / *minimiser_s;
}

const ConvergencePoint* first_at_accuracy(const std::vector<ConvergencePoint>& series,
                                          double level_um) {
  const ConvergencePoint* best = nullptr;
  for (const auto& p : series) {
    if (p.axial_error_um > level_um) continue;
    // Minimiser: the accuracy must hold for every tighter tolerance too, so that a lucky
    // early stop of a loose solve does not count.
    const bool stays =
        p.kind == ConvergenceKind::monte_carlo ||
        std::all_of(series.begin(), series.end(), [&](const ConvergencePoint& q) {
          return q.force_tolerance_pN > p.force_tolerance_pN || q.axial_error_um <= level_um;
        });
    if (stays && (!best || p.wall_s < best->wall_s)) best = &p;
  }
  return best;
}

std::vector<TimeToAccuracy> time_to_accuracy_table(const McConvergenceResult& r) {
  std::vector<TimeToAccuracy> out;
  for (double rel : r.options.relative_accuracies) {
    TimeToAccuracy t;
    t.relative = rel;
    t.level_um = rel * r.reference.axial_um;
    if (const ConvergencePoint* p = first_at_accuracy(r.minimiser, t.level_um))
      t.minimiser_s = p->wall_s;
    if (const ConvergencePoint* p = first_at_accuracy(r.mc, t.level_um)) {
      t.mc_s = p->wall_s;
      t.mc_sweeps = p->sweeps;
    }
    out.push_back(t);
  }
  return out;
}

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// One minimiser solve from the rest shape, as a discrete method run solves one force
/// (solve_equilibrium, the call run_stretch makes per force), timed around the solve only.
struct RestSolve {
  StretchPoint point;
  ConstraintMultipliers lambda;
  double wall_s = 0;
};

RestSolve solve_from_rest(const Network& net, double force_pN, const StretchOptions& options) {
  RestSolve s;
  Positions x = net.rest;
  const auto t0 = Clock::now();
  s.point = solve_equilibrium(net, force_pN, x, s.lambda, options);
  s.wall_s = seconds_since(t0);
  return s;
}

ConvergencePoint minimiser_point(const RestSolve& s, double tolerance_pN,
                                 const McConvergenceReference& ref) {
  ConvergencePoint p;
  p.kind = ConvergenceKind::minimiser;
  p.wall_s = s.wall_s;
  p.axial_um = s.point.axial_um;
  p.transverse_um = s.point.transverse_um;
  p.axial_error_um = std::abs(p.axial_um - ref.axial_um);
  p.transverse_error_um = std::abs(p.transverse_um - ref.transverse_um);
  p.force_tolerance_pN = tolerance_pN;
  p.iterations = s.point.iterations;
  p.converged = s.point.converged;
  return p;
}

/// Runs the chain for the budget, recording at a fixed sweep interval or at ~100 wall times
/// spaced by a factor 10^(4/100) from budget/10^4 to the budget (log-spaced, as the chart).
void run_chain(const Network& net, const McConvergenceOptions& o, McConvergenceResult& res,
               const ProgressSink& progress) {
  McOptions mo;
  mo.temperature_K = o.mc_temperature_K;
  mo.seed = o.seed;
  mo.streams = 1;
  // The step adapts throughout: at T = 0 detailed balance is not the point, and a quench
  // needs ever smaller steps as it closes in on the minimum.
  mo.adapt_sweeps = std::numeric_limits<int>::max();
  mo.target_acceptance = o.mc_target_acceptance;
  LoadState load;
  load.force_pN = o.force_pN;
  load.multipliers = res.reference.multipliers;
  const double factor = std::pow(10.0, 4.0 / 100.0);
  double next_sample_s = o.mc_budget_s * 1e-4, next_report_s = 0.1 * o.mc_budget_s;
  const auto t0 = Clock::now();  // sampler set-up (colouring, caches) counts as MC work
  McSampler mc(net, load, net.rest, mo);
  for (long long sweeps = 1;; ++sweeps) {
    mc.sweep();
    const double t = seconds_since(t0);
    const bool done = o.mc_sweeps > 0 ? sweeps >= o.mc_sweeps : t >= o.mc_budget_s;
    const bool due =
        o.sample_every_sweeps > 0 ? sweeps % o.sample_every_sweeps == 0 : t >= next_sample_s;
    if (due || done) {
      const Diameters d = measure_diameters(mc.positions());
      ConvergencePoint p;
      p.kind = ConvergenceKind::monte_carlo;
      p.wall_s = t;
      p.axial_um = d.axial_um;
      p.transverse_um = d.transverse_um;
      p.axial_error_um = std::abs(d.axial_um - res.reference.axial_um);
      p.transverse_error_um = std::abs(d.transverse_um - res.reference.transverse_um);
      p.sweeps = sweeps;
      p.step_um = mc.step_um();
      res.mc.push_back(p);
      while (next_sample_s <= t) next_sample_s *= factor;
      if (t >= next_report_s || done) {
        std::ostringstream m;
        m << "mc_convergence: Monte Carlo " << t << " s, " << sweeps << " sweeps, D_A error "
          << p.axial_error_um << " um, step " << p.step_um << " um";
        report(progress, m.str());
        while (next_report_s <= t) next_report_s += 0.1 * o.mc_budget_s;
      }
    }
    if (done) {
      res.mc_wall_s = t;
      return;
    }
  }
}

}  // namespace

McConvergenceResult run_mc_convergence(const McConvergenceOptions& o,
                                       const ProgressSink& progress) {
  o.validate();
  McConvergenceResult res;
  res.options = o;
  const Network net = make_discrete_network(o.vertices, 0, o.parameters);
  res.vertices = net.topo.num_vertices;
  const std::string tag = "mc_convergence (N = " + std::to_string(res.vertices) + ", " +
                          std::to_string(o.force_pN) + " pN): ";

  report(progress, tag + "reference solve (default stretch options)");
  const StretchOptions defaults;
  const RestSolve ref = solve_from_rest(net, o.force_pN, defaults);
  res.reference.axial_um = ref.point.axial_um;
  res.reference.transverse_um = ref.point.transverse_um;
  res.reference.multipliers = ref.lambda;
  res.reference.force_tolerance_pN = defaults.minimiser.force_tolerance;
  res.reference.wall_s = ref.wall_s;
  res.reference.residual_pN = ref.point.residual_pN;
  res.reference.converged = ref.point.converged;

  for (double tol : o.force_tolerances_pN) {
    report(progress, tag + "minimiser at force tolerance " + std::to_string(tol) + " pN");
    StretchOptions so;
    so.minimiser.force_tolerance = tol;
    res.minimiser.push_back(
        minimiser_point(solve_from_rest(net, o.force_pN, so), tol, res.reference));
  }

  report(progress, tag + "Monte Carlo at " + std::to_string(o.mc_temperature_K) + " K for " +
                       std::to_string(o.mc_budget_s) + " s");
  run_chain(net, o, res, progress);
  res.time_to_accuracy = time_to_accuracy_table(res);
  return res;
}

namespace {

std::string percent(double fraction) {
  std::ostringstream s;
  s.precision(3);
  s << 100 * fraction << " %";
  return s.str();
}

std::string seconds(double s) {
  std::ostringstream out;
  out.precision(3);
  out << s << " s";
  return out.str();
}

}  // namespace

std::string mc_convergence_conclusion(const McConvergenceResult& r) {
  // Levels from loose to tight: the tightest reached by both, and the first reached by only one.
  std::vector<TimeToAccuracy> levels = r.time_to_accuracy;
  std::sort(levels.begin(), levels.end(),
            [](const auto& a, const auto& b) { return a.relative > b.relative; });
  const TimeToAccuracy* both = nullptr;
  const TimeToAccuracy* one = nullptr;
  for (const auto& t : levels) {
    if (t.ratio()) both = &t;
    if (!one && static_cast<bool>(t.minimiser_s) != static_cast<bool>(t.mc_s)) one = &t;
  }
  std::ostringstream s;
  s.precision(3);
  if (both) {
    const double ratio = *both->ratio();
    s << "At " << percent(both->relative) << " of D_A, the tightest level both reach, Monte Carlo "
      << "needs " << seconds(*both->mc_s) << " against " << seconds(*both->minimiser_s)
      << " for the minimiser, " << (ratio >= 1 ? ratio : 1 / ratio) << " times "
      << (ratio >= 1 ? "slower" : "faster") << ".";
  } else {
    s << "No accuracy level is reached by both methods.";
  }
  if (one) {
    const double final_error = r.mc.empty() ? std::nan("") : r.mc.back().axial_error_um;
    s << " ";
    if (one->minimiser_s)
      s << "Within its " << seconds(r.options.mc_budget_s) << " budget (" << r.mc.size()
        << " samples, " << (r.mc.empty() ? 0 : r.mc.back().sweeps)
        << " sweeps) Monte Carlo does not reach " << percent(one->relative) << " (final D_A error "
        << final_error << " um = " << percent(final_error / r.reference.axial_um)
        << "), which the minimiser reaches in " << seconds(*one->minimiser_s) << ".";
    else
      s << "Monte Carlo reaches " << percent(one->relative) << " in " << seconds(*one->mc_s)
        << ", which no minimiser tolerance tried reaches.";
  }
  return s.str();
}

void write_mc_convergence(const McConvergenceResult& r, const std::string& dir) {
  ensure_output_directory(dir);
  const McConvergenceOptions& o = r.options;
  std::ostringstream head;
  head << "Monte Carlo (" << o.mc_temperature_K << " K) against the minimiser at " << o.force_pN
       << " pN, N = " << r.vertices << ", Monte Carlo budget " << o.mc_budget_s << " s";
  CsvTable all;
  all.comments = {head.str(),
                  "reference: minimiser at " + std::to_string(r.reference.force_tolerance_pN) +
                      " pN from the rest shape: D_A " + std::to_string(r.reference.axial_um) +
                      " um, D_T " + std::to_string(r.reference.transverse_um) + " um",
                  "kind: 0 minimiser (one solve per force tolerance), 1 Monte Carlo (one row per "
                  "sample); wall_s: minimiser solve only, Monte Carlo since the sampler set-up"};
  all.header = {"kind",
                "wall_s",
                "axial_um",
                "transverse_um",
                "axial_error_um",
                "transverse_error_um",
                "force_tolerance_pN",
                "iterations",
                "converged",
                "sweeps",
                "step_um"};
  auto row = [](const ConvergencePoint& p) {
    return std::vector<double>{p.kind == ConvergenceKind::minimiser ? 0.0 : 1.0,
                               p.wall_s,
                               p.axial_um,
                               p.transverse_um,
                               p.axial_error_um,
                               p.transverse_error_um,
                               p.force_tolerance_pN,
                               static_cast<double>(p.iterations),
                               p.converged ? 1.0 : 0.0,
                               static_cast<double>(p.sweeps),
                               p.step_um};
  };
  auto json_point = [](const ConvergencePoint& p) {
    nlohmann::json j = {{"wall_s", p.wall_s},
                        {"axial_um", p.axial_um},
                        {"transverse_um", p.transverse_um},
                        {"axial_error_um", p.axial_error_um},
                        {"transverse_error_um", p.transverse_error_um}};
    if (p.kind == ConvergenceKind::minimiser) {
      j["force_tolerance_pN"] = p.force_tolerance_pN;
      j["iterations"] = p.iterations;
      j["converged"] = p.converged;
    } else {
      j["sweeps"] = p.sweeps;
      j["step_um"] = p.step_um;
    }
    return j;
  };
  nlohmann::json minimiser = nlohmann::json::array(), mc = nlohmann::json::array();
  for (const auto& p : r.minimiser) {
    all.rows.push_back(row(p));
    minimiser.push_back(json_point(p));
  }
  for (const auto& p : r.mc) {
    all.rows.push_back(row(p));
    mc.push_back(json_point(p));
  }
  write_csv(dir + "/mc_convergence.csv", all);

  // A level not reached says so in words (never null, which JSON readers take for a number).
  auto optional_json = [](const auto& v) {
    return v ? nlohmann::json(*v) : nlohmann::json("not reached");
  };
  nlohmann::json table = nlohmann::json::array();
  for (const auto& t : r.time_to_accuracy)
    table.push_back({{"relative_accuracy", t.relative},
                     {"level_um", t.level_um},
                     {"minimiser_s", optional_json(t.minimiser_s)},
                     {"mc_s", optional_json(t.mc_s)},
                     {"mc_sweeps", optional_json(t.mc_sweeps)},
                     {"mc_over_minimiser", optional_json(t.ratio())}});
  const nlohmann::json j = {
      {"force_pN", o.force_pN},
      {"vertices", r.vertices},
      {"mc_temperature_K", o.mc_temperature_K},
      {"mc_budget_s", o.mc_budget_s},
      {"mc_wall_s", r.mc_wall_s},
      {"mc_seed", o.seed},
      {"mc_target_acceptance", o.mc_target_acceptance},
      {"reference",
       {{"axial_um", r.reference.axial_um},
        {"transverse_um", r.reference.transverse_um},
        {"lambda_area_pN_per_um", r.reference.multipliers.area_pN_per_um},
        {"lambda_volume_pN_per_um2", r.reference.multipliers.volume_pN_per_um2},
        {"force_tolerance_pN", r.reference.force_tolerance_pN},
        {"residual_pN", r.reference.residual_pN},
        {"converged", r.reference.converged},
        {"wall_s", r.reference.wall_s},
        {"how", "minimiser (solve_equilibrium, default stretch options) from the rest shape"}}},
      {"minimiser", minimiser},
      {"monte_carlo", mc},
      {"time_to_accuracy", table},
      {"conclusion", mc_convergence_conclusion(r)}};
  write_text_atomic(dir + "/mc_convergence.json", j.dump(2) + "\n");

  // Chart. Errors below kFloor (a solve that reproduces the reference) sit on the floor; the
  // minimiser's points are joined in the order of tightening tolerance and labelled with it.
  constexpr double kFloor = 1e-6;
  PlotSpec spec;
  spec.title = head.str();
  spec.xlabel = "wall time (s)";
  spec.ylabel = "|error| in D_{A} against the minimiser reference (µm)";
  spec.log_x = spec.log_y = true;
  spec.key = "inside left bottom opaque box";  // the corner neither method reaches first
  std::ostringstream floor_text, y_range;
  floor_text << kFloor;
  y_range << "[" << kFloor / 2 << ":*]";
  spec.y_range = y_range.str();
  spec.extra_commands = {"set format y '10^{%L}'"};
  auto series_file = [&](const std::vector<ConvergencePoint>& pts, const std::string& name) {
    CsvTable t;
    t.comments = {"errors below " + floor_text.str() + " um are plotted at that floor"};
    t.header = {"wall_s", "axial_error_um", "force_tolerance_pN"};
    for (const auto& p : pts)
      t.rows.push_back({p.wall_s, std::max(p.axial_error_um, kFloor), p.force_tolerance_pN});
    write_csv(dir + "/" + name, t);
    return name;
  };
  const std::string mini_file = series_file(r.minimiser, "mc_convergence_minimiser.csv");
  std::ostringstream mc_title;
  mc_title << "Monte Carlo (" << o.mc_temperature_K << " K)";
  spec.series.push_back({mc_title.str(), series_file(r.mc, "mc_convergence_mc.csv"), "1:2", "lines",
                         "#d62728", 7, 1});
  spec.series.push_back({"minimiser (one solve per force tolerance)", mini_file, "1:2",
                         "linespoints", "#1f77b4", 7, 1});
  spec.series.push_back({"", mini_file, "1:2:(sprintf(\"%g pN\", $3))",
                         "labels left offset 0.8,0 font ',9'", "#1f77b4", 7, 1});
  // Accuracy levels as dashed horizontal lines across the plot, labelled at the left.
  for (const auto& t : r.time_to_accuracy) {
    std::ostringstream arrow, label;
    arrow << "set arrow from graph 0, first " << t.level_um << " to graph 1, first " << t.level_um
          << " nohead dt 2 lw 1 lc rgb '#777777'";
    label << "set label '" << percent(t.relative) << " of D_{A}' at graph 0.01, first "
          << t.level_um << " offset 0,0.6 tc rgb '#555555'";
    spec.extra_commands.push_back(arrow.str());
    spec.extra_commands.push_back(label.str());
  }
  render_plot(spec, dir, "mc_convergence");
}

}  // namespace rbc
