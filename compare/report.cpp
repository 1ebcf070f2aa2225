#include "compare/report.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>

#include "core/io.hpp"

namespace rbc {
namespace {

const MethodRun* find_run(const Fig7Result& r, MethodKind kind, WlcExpansion order) {
  for (const auto& run : r.runs)
    if (run.method.kind == kind && (kind == MethodKind::discrete || run.method.order == order))
      return &run;
  return nullptr;
}

std::string fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

/// A table value: 4 decimals, or 2 significant digits in scientific notation when that would
/// print a non-zero value as 0.0000 (area drifts of 1e-5, say).
std::string table_value(double v) {
  if (v == 0 || std::abs(v) >= 1e-3) return fixed(v, 4);
  std::ostringstream s;
  s << std::scientific << std::setprecision(1) << v;
  return s.str();
}

/// A speed ratio with as many decimals as make it readable: 26x, 3.4x, 0.031x.
std::string ratio_text(double ratio) {
  return fixed(ratio, ratio >= 10 ? 0 : ratio >= 1 ? 1 : 3) + "x";
}

/// Report subsection of the Monte Carlo convergence study: chart, time-to-accuracy table and
/// the conclusion computed from it.
void write_mc_convergence_section(std::ostream& md, const McConvergenceResult& r) {
  const McConvergenceOptions& o = r.options;
  md << "\n### Time to the same accuracy: Monte Carlo against the minimiser\n\n"
     << "The zero-temperature answer of one network (N = " << r.vertices << ", "
     << fixed(o.force_pN, 0) << " pN), both from the rest shape. Reference: the minimiser at "
     << r.reference.force_tolerance_pN << " pN, D_A = " << fixed(r.reference.axial_um, 4)
     << " um, D_T = " << fixed(r.reference.transverse_um, 4)
     << " um. Minimiser: one solve per force tolerance, timed around the solve. Monte Carlo: "
     << (o.mc_temperature_K == 0 ? std::string("a quench at 0 K (downhill moves only)")
                                 : "Metropolis at " + fixed(o.mc_temperature_K, 0) + " K")
     << " with the trial step adapting to " << fixed(100 * o.mc_target_acceptance, 0)
     << " % acceptance and the area and volume multipliers held at the reference's (a head "
        "start: its times are lower bounds), run for "
     << fixed(r.mc_wall_s, 1) << " s (" << (r.mc.empty() ? 0 : r.mc.back().sweeps)
     << " sweeps).\n\n![time to accuracy](tradeoff/mc_convergence.png)\n\n"
     << "| accuracy (of D_A) | level (um) | minimiser (s) | Monte Carlo (s) | Monte Carlo / "
        "minimiser |\n|---|---|---|---|---|\n";
  for (const auto& t : r.time_to_accuracy) {
    md << "| " << fixed(100 * t.relative, 1) << " % | " << fixed(t.level_um, 4) << " | "
       << (t.minimiser_s ? fixed(*t.minimiser_s, 3) : "not reached") << " | "
       << (t.mc_s ? fixed(*t.mc_s, 3) + " (" + std::to_string(*t.mc_sweeps) + " sweeps)"
                  : "not reached in " + fixed(r.mc_wall_s, 1) + " s")
       << " | " << (t.ratio() ? ratio_text(*t.ratio()) : "") << " |\n";
  }
  // When even the loosest tolerance beats every level, the minimiser's times are upper bounds.
  const auto loosest = std::max_element(
      r.minimiser.begin(), r.minimiser.end(),
      [](const auto& a, const auto& b) { return a.force_tolerance_pN < b.force_tolerance_pN; });
  double tightest_level_um = std::numeric_limits<double>::infinity();
  for (const auto& t : r.time_to_accuracy)
    tightest_level_um = std::min(tightest_level_um, t.level_um);
  if (loosest != r.minimiser.end() && loosest->axial_error_um <= tightest_level_um)
    md << "\nThe loosest tolerance tried (" << loosest->force_tolerance_pN
       << " pN) already gives D_A within "
       << fixed(100 * loosest->axial_error_um / r.reference.axial_um, 3)
       << " %, so the minimiser's times are upper bounds at every level.\n";
  md << "\n"
     << mc_convergence_conclusion(r)
     << " Data: `tradeoff/mc_convergence.csv`, `tradeoff/mc_convergence.json`.\n";
}

}  // namespace

std::vector<ClaimCheck> check_claims(const Fig7Result& fig7, const TradeoffResult& tradeoff,
                                     const StabilityResult& stability) {
  std::vector<ClaimCheck> out;
  // 1. Order 2 matches the microscopic model up to 200 pN.
  {
    ClaimCheck c{"The continuum model with p = 2 agrees with the microscopic model up to 200 pN",
                 "", ""};
    const MethodRun* d = find_run(fig7, MethodKind::discrete, WlcExpansion::full);
    const MethodRun* p2 = find_run(fig7, MethodKind::continuum, WlcExpansion::order2);
    if (!d || !p2) {
      c.verdict = "not checked";
      c.evidence = "Fig. 7 did not run both the discrete model and continuum p = 2";
    } else {
      double worst_a = 0, worst_t = 0, at_a = 0;
      for (size_t k = 0; k < d->points.size() && k < p2->points.size(); ++k) {
        if (d->points[k].force_pN > 200.0) break;
        const double ea = std::abs(p2->points[k].axial_um / d->points[k].axial_um - 1);
        const double et = std::abs(p2->points[k].transverse_um / d->points[k].transverse_um - 1);
        if (ea > worst_a) at_a = d->points[k].force_pN;
        worst_a = std::max(worst_a, ea);
        worst_t = std::max(worst_t, et);
      }
      c.verdict = worst_a <= 0.02 && worst_t <= 0.05 ? "holds" : "holds only approximately";
      c.evidence = "largest relative difference 0-200 pN: D_A " + fixed(100 * worst_a, 2) +
                   " % (at " + fixed(at_a, 1) + " pN), D_T " + fixed(100 * worst_t, 2) + " % (" +
                   d->method.label() + " vs " + p2->method.label() + "; fig7/fig7_*.csv)";
    }
    out.push_back(c);
  }
  // 2. Above 200 pN the full WLC is needed: the Taylor orders stay close to the full law
  // below 200 pN but part from it (or stretch links past Lmax, which the WLC forbids) above.
  {
    ClaimCheck c{"Above ~200 pN the full WLC law is needed (the Taylor orders part from it)", "",
                 ""};
    std::ostringstream ev;
    bool any = false, early = false, parts_above = false;
    for (const auto& row : stability.rows) {
      if (row.study != StabilityStudy::taylor_order) continue;
      if (row.metric == StabilityMetric::departure_force_pN && row.parameter_value == 0.05) {
        any = true;
        ev << row.method << " departs by 5 % at "
           << (row.value ? fixed(*row.value, 0) + " pN" : "no ladder force") << "; ";
        if (row.value) (*row.value < 200 ? early : parts_above) = true;
      }
      if (row.metric == StabilityMetric::unphysical_from_force_pN) {
        ev << row.method << " stretches a link past Lmax (or fails) from "
           << (row.value ? fixed(*row.value, 0) + " pN" : "no ladder force") << "; ";
        if (row.value) (*row.value < 200 ? early : parts_above) = true;
      }
    }
    c.verdict = !any          ? "not checked"
                : early       ? "does not hold as stated (departure below 200 pN)"
                : parts_above ? "holds"
                              : "not shown: the orders stay within 5 % over the whole ladder";
    c.evidence = any ? ev.str() + "(stability/stability.csv)" : "stability study without continuum";
    out.push_back(c);
  }
  // 3. The continuum model is much cheaper at equal accuracy.
  {
    ClaimCheck c{"The continuum model is much cheaper than the microscopic one at equal accuracy",
                 "", ""};
    auto fastest = [&](MethodKind kind, double tol) -> const TradeoffRow* {
      const TradeoffRow* best = nullptr;
      for (const auto& r : tradeoff.rows)
        if (r.run.method.kind == kind && r.converged &&
            r.axial_error_um <= tol * tradeoff.reference.axial_um &&
            (!best || r.wall_s < best->wall_s))
          best = &r;
      return best;
    };
    std::ostringstream ev;
    bool checked = false;
    for (double tol : {0.01, 0.05}) {
      const TradeoffRow* d = fastest(MethodKind::discrete, tol);
      const TradeoffRow* k = fastest(MethodKind::continuum, tol);
      ev << "within " << fixed(100 * tol, 0) << " % of the reference D_A at "
         << fixed(tradeoff.force_pN, 0) << " pN: ";
      if (d && k) {
        checked = true;
        ev << "fastest discrete " << d->run.method.label() << " " << fixed(d->wall_s, 2)
           << " s, fastest continuum " << k->run.method.label() << " " << fixed(k->wall_s, 2)
           << " s (ratio " << fixed(d->wall_s / k->wall_s, 1) << "x); ";
      } else {
        ev << (d ? "" : "no discrete run ") << (k ? "" : "no continuum run ") << "reaches it; ";
      }
    }
    c.verdict = checked ? "see ratios" : "not established at these tolerances";
    c.evidence = ev.str() + "reference: " + tradeoff.reference.how + " (tradeoff/tradeoff.csv)";
    out.push_back(c);
  }
  return out;
}

void run_report(const ReportOptions& o, const std::string& dir, const ProgressSink& progress) {
  ensure_output_directory(dir);
  const Fig7Result fig7 = run_fig7(o.fig7, progress);
  write_fig7(fig7, dir + "/fig7");
  const TradeoffResult trade = run_tradeoff(o.tradeoff, progress);
  write_tradeoff(trade, dir + "/tradeoff");
  std::optional<McConvergenceResult> mc;
  if (o.include_mc_convergence) {
    mc = run_mc_convergence(o.mc_convergence, progress);
    write_mc_convergence(*mc, dir + "/tradeoff");
  }
  const StabilityResult stab = run_stability(o.stability, &trade, progress);
  write_stability(stab, dir + "/stability");
  const auto claims = check_claims(fig7, trade, stab);

  std::ostringstream md;
  md << "# Red blood cell stretch: microscopic and continuum models against Mills 2004\n\n"
     << "Generated by `rbc report`. Every number below is read from the CSV files beside this "
        "report; units are um, pN and s.\n\n## The paper's claims\n\n| claim | verdict | evidence "
        "|\n"
        "|---|---|---|\n";
  for (const auto& c : claims)
    md << "| " << c.claim << " | " << c.verdict << " | " << c.evidence << " |\n";
  md << "\n## Fig. 7: diameters against force\n\n![Fig. 7](fig7/fig7.png)\n\n"
     << "Goodness of fit against the main reading of Mills et al. 2004 (0-193 pN; "
        "`fig7/fig7_fit.csv`). The reading itself is uncertain by up to 1.2 um "
        "(`fig7/experiment_mills2004_alternative.csv`), so agreement tighter than ~0.5 um is "
        "not meaningful.\n\n| method | D_A rms (um) | inside | D_T rms (um) | inside | wall (s) |\n"
        "|---|---|---|---|---|---|\n";
  for (size_t k = 0; k < fig7.runs.size(); ++k) {
    const auto& q = fig7.fits[k];
    md << "| " << fig7.runs[k].method.label() << " | " << fixed(q.axial_rms_um, 2) << " | "
       << q.axial_inside << "/" << q.points << " | " << fixed(q.transverse_rms_um, 2) << " | "
       << q.transverse_inside << "/" << q.points << " | " << fixed(fig7.runs[k].total_s, 1)
       << (fig7.runs[k].all_converged() ? "" : " (not all converged)") << " |\n";
  }
  md << "\n## Speed against accuracy at " << fixed(trade.force_pN, 0) << " pN\n\n"
     << "Reference: D_A = " << fixed(trade.reference.axial_um, 4) << " +- "
     << fixed(trade.reference.axial_error_um, 4)
     << " um, D_T = " << fixed(trade.reference.transverse_um, 4) << " +- "
     << fixed(trade.reference.transverse_error_um, 4) << " um; " << trade.reference.how
     << ".\n\n![accuracy vs time, D_A](tradeoff/tradeoff_axial.png)\n"
     << "![accuracy vs time, D_T](tradeoff/tradeoff_transverse.png)\n\n"
     << "| method | vertices | D_A (um) | error D_A | D_T (um) | error D_T | wall (s) | Pareto |\n"
        "|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : trade.rows)
    md << "| " << r.run.method.label() << " | " << r.run.vertices << " | " << fixed(r.axial_um, 4)
       << " | " << fixed(r.axial_error_um, 4) << " | " << fixed(r.transverse_um, 4) << " | "
       << fixed(r.transverse_error_um, 4) << " | " << fixed(r.wall_s, 2) << " | "
       << (r.pareto ? "yes" : "") << (r.converged ? "" : " (not converged)") << " |\n";
  md << "\nNote: the continuum model converges to the continuum limit of the network, so its "
        "error against the discrete reference includes the homogenisation error (and the "
        "discrete network's residual prestress, MODEL.md section 2), not only discretisation.\n";
  if (mc) write_mc_convergence_section(md, *mc);
  md << "\n## Where methods stop working\n\n";
  if (!stab.orders.empty())
    md << "![Taylor orders vs full WLC](stability/stability_orders.png)\n\n";
  md << "| study | method | parameter | value | metric | result | note "
        "|\n|---|---|---|---|---|---|---|\n";
  for (const auto& r : stab.rows)
    md << "| " << to_string(r.study) << " | " << r.method << " | " << r.parameter << " | "
       << r.parameter_value << " | " << to_string(r.metric) << " | "
       << (r.value ? table_value(*r.value) : "not reached") << " | " << r.note << " |\n";
  md << "\nAll rows: `stability/stability.csv`.\n";
  write_text_atomic(dir + "/report.md", md.str());
}

}  // namespace rbc
