// SPDX-License-Identifier: GPL-3.0-or-later
#include "compare/fig7.hpp"

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "compare/plot.hpp"
#include "core/io.hpp"

namespace rbc {

std::vector<Method> default_fig7_methods() {
  std::vector<Method> m;
  m.push_back({MethodKind::discrete, 2000, WlcExpansion::full});
  for (auto order :
       {WlcExpansion::order2, WlcExpansion::order3, WlcExpansion::order4, WlcExpansion::full})
    m.push_back({MethodKind::continuum, 4000, order});
  return m;
}

void check_increasing_forces(const std::vector<double>& f) {
  for (size_t k = 0; k < f.size(); ++k) {
    if (!(f[k] >= 0) || !std::isfinite(f[k]))
      throw std::invalid_argument("force " + std::to_string(f[k]) + " pN must be finite and >= 0");
    if (k > 0 && !(f[k] > f[k - 1]))
      throw std::invalid_argument("forces must increase: " + std::to_string(f[k]) + " pN follows " +
                                  std::to_string(f[k - 1]) + " pN");
  }
}

Fig7Result run_fig7(const Fig7Options& o, const ProgressSink& progress) {
  check_increasing_forces(o.forces_pN);
  const std::string data = o.data_dir.empty() ? default_data_directory() : o.data_dir;
  Fig7Result r;
  r.provenance = o.provenance;
  r.experiment = load_experiment(data + "/mills2004_optical_tweezers.csv");
  r.alternative = load_experiment(data + "/mills2004_alternative_reading.csv");
  const std::vector<Method> methods = o.methods.empty() ? default_fig7_methods() : o.methods;
  for (const Method& m : methods) {
    report(progress, "fig7: running " + m.label());
    RunMethodOptions ro;
    ro.parameters = o.parameters;
    r.runs.push_back(run_method(m, o.forces_pN, progress, ro));
    std::vector<CurveSample> curve;
    for (const auto& p : r.runs.back().points)
      curve.push_back({p.force_pN, p.axial_um, p.transverse_um});
    r.fits.push_back(fit_quality(r.experiment, curve));
  }
  return r;
}

namespace {

void write_experiment_csv(const std::vector<ExperimentPoint>& e, const std::string& path,
                          const std::string& what) {
  CsvTable t;
  t.comments = {what, "Mills et al. 2004, Mech. Chem. Biosyst. 1:169 (values read off the figure)",
                "units: pN, um; err = half the error bar"};
  t.header = {"force_pN", "axial_um", "axial_err_um", "transverse_um", "transverse_err_um"};
  for (const auto& p : e)
    t.rows.push_back(
        {p.force_pN, p.axial_um, p.axial_err_um, p.transverse_um, p.transverse_err_um});
  write_csv(path, t);
}

}  // namespace

void write_fig7(const Fig7Result& r, const std::string& dir) {
  ensure_output_directory(dir);
  write_experiment_csv(r.experiment, dir + "/experiment_mills2004.csv",
                       "experiment (main reading)");
  write_experiment_csv(r.alternative, dir + "/experiment_mills2004_alternative.csv",
                       "experiment (alternative reading)");
  static const char* palette[] = {"#000000", "#1f77b4", "#2ca02c", "#ff7f0e",
                                  "#d62728", "#9467bd", "#8c564b", "#e377c2"};
  PlotSpec spec;
  spec.title = "Optical-tweezers stretch of a red blood cell (Fig. 7, Hartmann 2008)";
  spec.xlabel = "total stretching force F (pN)";
  spec.ylabel = "diameter (µm)";
  spec.y_range = "[0:*]";
  spec.key = "inside right center box opaque";
  spec.width_px = 1100;
  spec.extra_commands = {"set label 'axial D_{A}' at graph 0.03, graph 0.93",
                         "set label 'transverse D_{T}' at graph 0.03, graph 0.12"};
  spec.series.push_back(
      {"Mills 2004 D_{A}", "experiment_mills2004.csv", "1:2:3", "yerrorbars", "#555555", 7, 1});
  spec.series.push_back(
      {"Mills 2004 D_{T}", "experiment_mills2004.csv", "1:4:5", "yerrorbars", "#555555", 5, 1});
  spec.series.push_back({"alternative reading (D_{A}, D_{T})",
                         "experiment_mills2004_alternative.csv", "1:2", "points", "#aaaaaa", 6, 1});
  spec.series.push_back(
      {"", "experiment_mills2004_alternative.csv", "1:4", "points", "#aaaaaa", 6, 1});
  CsvTable fit;
  fit.comments = {"goodness of fit against Mills 2004 (main reading), 0-193 pN",
                  "rms in um; inside = points within their error bars"};
  fit.label_header = "method";
  fit.header = {"axial_rms_um", "transverse_rms_um", "axial_inside", "transverse_inside",
                "points",       "total_wall_s",      "all_converged"};
  nlohmann::json summary = nlohmann::json::array();
  for (size_t k = 0; k < r.runs.size(); ++k) {
    const MethodRun& run = r.runs[k];
    const std::string file = "fig7_" + run.method.name() + ".csv";
    CsvTable t;
    t.comments = {run.method.label(), "units: pN, um, s"};
    t.header = {"force_pN", "axial_um", "transverse_um", "wall_s", "converged", "residual"};
    for (const auto& p : run.points)
      t.rows.push_back(
          {p.force_pN, p.axial_um, p.transverse_um, p.wall_s, p.converged ? 1.0 : 0.0, p.residual});
    t.comments.insert(t.comments.end(), r.provenance.begin(), r.provenance.end());
    write_csv(dir + "/" + file, t);
    const char* color = palette[(k + 1) % 8];
    const int dash = run.method.kind == MethodKind::discrete ? 1 : 2;
    spec.series.push_back({run.method.label(), file, "1:2", "lines", color, 7, dash});
    spec.series.push_back({"", file, "1:3", "lines", color, 7, dash});
    const FitQuality& q = r.fits[k];
    fit.labels.push_back(run.method.name());
    fit.rows.push_back({q.axial_rms_um, q.transverse_rms_um, static_cast<double>(q.axial_inside),
                        static_cast<double>(q.transverse_inside), static_cast<double>(q.points),
                        run.total_s, run.all_converged() ? 1.0 : 0.0});
    summary.push_back({{"method", run.method.name()},
                       {"label", run.method.label()},
                       {"vertices", run.vertices},
                       {"elements", run.elements},
                       {"axial_rms_um", q.axial_rms_um},
                       {"transverse_rms_um", q.transverse_rms_um},
                       {"axial_inside", q.axial_inside},
                       {"transverse_inside", q.transverse_inside},
                       {"points", q.points},
                       {"total_wall_s", run.total_s},
                       {"all_converged", run.all_converged()},
                       {"data", file}});
  }
  fit.comments.insert(fit.comments.end(), r.provenance.begin(), r.provenance.end());
  write_csv(dir + "/fig7_fit.csv", fit);
  write_text_atomic(dir + "/fig7.json", summary.dump(2) + "\n");
  render_plot(spec, dir, "fig7");
}

}  // namespace rbc
