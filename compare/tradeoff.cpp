// SPDX-License-Identifier: GPL-3.0-or-later
#include "compare/tradeoff.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "compare/plot.hpp"
#include "core/io.hpp"

namespace rbc {

TradeoffReference richardson_reference(const std::vector<TradeoffRow>& rows) {
  std::vector<const TradeoffRow*> d;
  for (const auto& r : rows)
    if (r.run.method.kind == MethodKind::discrete && r.converged) d.push_back(&r);
  if (d.empty()) throw std::runtime_error("no converged discrete run to serve as reference");
  std::sort(d.begin(), d.end(), [](auto* a, auto* b) { return a->run.vertices < b->run.vertices; });
  TradeoffReference ref;
  const TradeoffRow& f2 = *d.back();
  if (d.size() == 1) {
    ref.axial_um = f2.axial_um;
    ref.transverse_um = f2.transverse_um;
    ref.how = "finest discrete network (N = " + std::to_string(f2.run.vertices) +
              "), no extrapolation (only one converged discrete run)";
    return ref;
  }
  const TradeoffRow& f1 = *d[d.size() - 2];
  const double n1 = f1.run.vertices, n2 = f2.run.vertices;
  auto extrapolate = [&](double v1, double v2) { return (n2 * v2 - n1 * v1) / (n2 - n1); };
  ref.axial_um = extrapolate(f1.axial_um, f2.axial_um);
  ref.transverse_um = extrapolate(f1.transverse_um, f2.transverse_um);
  ref.axial_error_um = std::abs(ref.axial_um - f2.axial_um);
  ref.transverse_error_um = std::abs(ref.transverse_um - f2.transverse_um);
  std::ostringstream how;
  how << "Richardson extrapolation D = D_inf + c/N of the discrete networks N = " << f1.run.vertices
      << " and " << f2.run.vertices << "; its error is estimated as the correction size";
  ref.how = how.str();
  return ref;
}

void mark_pareto_front(std::vector<TradeoffRow>& rows) {
  std::vector<TradeoffRow*> order;
  for (auto& r : rows) {
    r.pareto = false;
    if (r.converged) order.push_back(&r);
  }
  std::sort(order.begin(), order.end(), [](auto* a, auto* b) { return a->wall_s < b->wall_s; });
  double best = std::numeric_limits<double>::infinity();
  for (auto* r : order)
    if (r->axial_error_um < best) {
      r->pareto = true;
      best = r->axial_error_um;
    }
}

TradeoffResult run_tradeoff(const TradeoffOptions& o, const ProgressSink& progress) {
  if (!(o.force_pN >= 0) || !std::isfinite(o.force_pN))
    throw std::invalid_argument("--force must be finite and >= 0, got " +
                                std::to_string(o.force_pN));
  TradeoffResult res;
  res.force_pN = o.force_pN;
  res.provenance = o.provenance;
  std::vector<Method> methods;
  for (int n : o.discrete_vertices)
    methods.push_back({MethodKind::discrete, n, WlcExpansion::full});
  if (o.include_continuum)
    for (auto order : o.continuum_orders)
      for (int e : o.continuum_elements) methods.push_back({MethodKind::continuum, e, order});
  for (const Method& m : methods) {
    report(progress, "tradeoff: " + m.label() + " at " + std::to_string(o.force_pN) + " pN");
    TradeoffRow row;
    RunMethodOptions ro;
    ro.parameters = o.parameters;
    row.run = run_method(m, {o.force_pN}, progress, ro);
    const CurvePoint& p = row.run.points.back();
    row.axial_um = p.axial_um;
    row.transverse_um = p.transverse_um;
    row.wall_s = row.run.total_s;
    row.converged = p.converged;
    res.rows.push_back(std::move(row));
  }
  res.reference = richardson_reference(res.rows);
  for (auto& r : res.rows) {
    r.axial_error_um = std::abs(r.axial_um - res.reference.axial_um);
    r.transverse_error_um = std::abs(r.transverse_um - res.reference.transverse_um);
  }
  mark_pareto_front(res.rows);
  return res;
}

void write_tradeoff(const TradeoffResult& r, const std::string& dir) {
  ensure_output_directory(dir);
  CsvTable all;
  all.comments = {"accuracy against wall time at " + std::to_string(r.force_pN) + " pN",
                  "reference: " + r.reference.how,
                  "reference D_A " + std::to_string(r.reference.axial_um) + " +- " +
                      std::to_string(r.reference.axial_error_um) + " um, D_T " +
                      std::to_string(r.reference.transverse_um) + " +- " +
                      std::to_string(r.reference.transverse_error_um) + " um",
                  "kind: 0 discrete, 1 continuum; order: 0 full, 2, 3, 4 (continuum law)"};
  all.label_header = "method";
  all.header = {"kind",      "order",          "resolution",          "vertices",
                "elements",  "axial_um",       "transverse_um",       "wall_s",
                "converged", "axial_error_um", "transverse_error_um", "pareto"};
  // One CSV per series so gnuplot can draw each with its own style.
  std::vector<std::pair<std::string, std::vector<const TradeoffRow*>>> series;
  auto series_for = [&](const std::string& name) -> std::vector<const TradeoffRow*>& {
    for (auto& s : series)
      if (s.first == name) return s.second;
    series.push_back({name, {}});
    return series.back().second;
  };
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& row : r.rows) {
    const Method& m = row.run.method;
    const int order = m.order == WlcExpansion::full     ? 0
                      : m.order == WlcExpansion::order2 ? 2
                      : m.order == WlcExpansion::order3 ? 3
                                                        : 4;
    all.labels.push_back(m.name());
    all.rows.push_back({m.kind == MethodKind::discrete ? 0.0 : 1.0,
                        m.kind == MethodKind::discrete ? 0.0 : static_cast<double>(order),
                        static_cast<double>(m.resolution), static_cast<double>(row.run.vertices),
                        static_cast<double>(row.run.elements), row.axial_um, row.transverse_um,
                        row.wall_s, row.converged ? 1.0 : 0.0, row.axial_error_um,
                        row.transverse_error_um, row.pareto ? 1.0 : 0.0});
    rows.push_back({{"method", m.name()},
                    {"label", m.label()},
                    {"vertices", row.run.vertices},
                    {"elements", row.run.elements},
                    {"axial_um", row.axial_um},
                    {"transverse_um", row.transverse_um},
                    {"wall_s", row.wall_s},
                    {"converged", row.converged},
                    {"axial_error_um", row.axial_error_um},
                    {"transverse_error_um", row.transverse_error_um},
                    {"pareto", row.pareto}});
    if (!row.converged) continue;
    series_for(m.kind == MethodKind::discrete ? "discrete" : "continuum_p" + to_string(m.order))
        .push_back(&row);
    if (row.pareto) series_for("pareto").push_back(&row);
  }
  all.comments.insert(all.comments.end(), r.provenance.begin(), r.provenance.end());
  write_csv(dir + "/tradeoff.csv", all);
  nlohmann::json j = {{"force_pN", r.force_pN},
                      {"reference",
                       {{"axial_um", r.reference.axial_um},
                        {"transverse_um", r.reference.transverse_um},
                        {"axial_error_um", r.reference.axial_error_um},
                        {"transverse_error_um", r.reference.transverse_error_um},
                        {"how", r.reference.how}}},
                      {"rows", rows}};
  write_text_atomic(dir + "/tradeoff.json", j.dump(2) + "\n");
  static const char* colors[] = {"#1f77b4", "#2ca02c", "#ff7f0e", "#d62728", "#9467bd"};
  for (const bool axial : {true, false}) {
    PlotSpec spec;
    spec.title = std::string("Accuracy against cost at ") +
                 std::to_string(static_cast<int>(r.force_pN)) + " pN (" +
                 (axial ? "axial D_{A}" : "transverse D_{T}") + ")";
    spec.xlabel = "wall time per solve incl. set-up (s)";
    spec.ylabel =
        std::string("|error| in ") + (axial ? "D_{A}" : "D_{T}") + " against the reference (µm)";
    spec.log_x = spec.log_y = true;
    int k = 0;
    for (auto& [name, pts] : series) {
      CsvTable t;
      t.header = {"wall_s", "error_um", "resolution"};
      std::vector<const TradeoffRow*> sorted = pts;
      std::sort(sorted.begin(), sorted.end(),
                [](auto* a, auto* b) { return a->wall_s < b->wall_s; });
      for (auto* p : sorted)
        t.rows.push_back({p->wall_s,
                          std::max(axial ? p->axial_error_um : p->transverse_error_um, 1e-6),
                          static_cast<double>(p->run.method.resolution)});
      const std::string file = "tradeoff_" + name + ".csv";
      write_csv(dir + "/" + file, t);
      if (name == "pareto") {
        if (axial)
          spec.series.push_back({"Pareto front (D_{A})", file, "1:2", "lines", "#777777", 7, 2});
      } else {
        // Legend in words: "continuum_p2" -> "continuum p = 2", "continuum_pfull" -> "continuum
        // full law" (the series name stays the file name).
        std::string legend = name;
        if (name.rfind("continuum_p", 0) == 0) {
          const std::string order = name.substr(11);
          legend = order == "full" ? "continuum full law" : "continuum p = " + order;
        }
        spec.series.push_back(
            {plot_literal(legend), file, "1:2", "linespoints", colors[k++ % 5], 7, 1});
      }
    }
    render_plot(spec, dir, axial ? "tradeoff_axial" : "tradeoff_transverse");
  }
}

}  // namespace rbc
