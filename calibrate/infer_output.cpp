// SPDX-License-Identifier: GPL-3.0-or-later
// Files of `rbc infer --out DIR`: summary, posterior samples, corner plot, predictive Fig. 7
// (the first data file's; with several, one per data file as well).
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "calibrate/infer.hpp"
#include "compare/plot.hpp"
#include "core/h5file.hpp"
#include "core/io.hpp"

namespace rbc {

namespace {
namespace fs = std::filesystem;

/// The method name without underscores (gnuplot's enhanced text reads them as subscripts).
std::string plain(std::string s) {
  for (char& c : s)
    if (c == '_') c = ' ';
  return s;
}

/// An axis label in the house style (compare/plot.hpp): the parameter's name and its unit, µm
/// with the micro sign.
std::string label(const InferenceResult& r, int k) {
  std::string unit = r.units[k];  // "um" as a word (um, pN s/um) shown as µm
  for (std::size_t at = find_word(unit, "um"); at != std::string::npos;
       at = find_word(unit, "um", at + 1))
    unit.replace(at, 2, "µm");
  const std::string text = plain(r.names[k]) + (unit == "1" ? "" : " (" + unit + ")");
  check_plot_text(text, "corner plot axis");
  return text;
}

/// Corner plot: histograms of each parameter's marginal on the diagonal, the samples of
/// each pair below it.
void write_corner(const InferenceResult& r, const std::string& dir) {
  const int d = static_cast<int>(r.samples.cols()), n = static_cast<int>(r.samples.rows());
  constexpr int kBins = 30;
  CsvTable hist;
  hist.comments = {"marginal histograms of the posterior samples: bin centre and density"};
  for (int k = 0; k < d; ++k) {
    hist.header.push_back(r.names[k] + "_centre");
    hist.header.push_back(r.names[k] + "_density");
  }
  hist.rows.assign(kBins, std::vector<double>(2 * d, 0.0));
  std::vector<double> lo(d), hi(d);
  for (int k = 0; k < d; ++k) {
    lo[k] = r.samples.col(k).minCoeff();
    hi[k] = r.samples.col(k).maxCoeff();
    if (!(hi[k] > lo[k])) hi[k] = lo[k] + 1e-12 * std::max(1.0, std::abs(lo[k]));
    const double w = (hi[k] - lo[k]) / kBins;
    for (int b = 0; b < kBins; ++b) hist.rows[b][2 * k] = lo[k] + (b + 0.5) * w;
    for (int i = 0; i < n; ++i) {
      const int b = std::min(kBins - 1, static_cast<int>((r.samples(i, k) - lo[k]) / w));
      hist.rows[b][2 * k + 1] += 1.0 / (n * w);
    }
  }
  write_csv((fs::path(dir) / "corner_marginals.csv").string(), hist);
  std::ostringstream g;
  const int px = 320 * d;
  g << "set terminal pngcairo size " << px << "," << px
    << " enhanced font 'DejaVu Sans,10'\n"
    // Run by hand the script writes corner.png; rbc passes the temporary's name.
    << "if (!exists('rbc_output')) rbc_output = 'corner.png'\n"
    << "set output rbc_output\n"
    << "set datafile separator ','\nset datafile commentschars '#'\n"
    << "set multiplot layout " << d << "," << d << " title 'posterior (" << plain(r.method) << ", "
    << n
    << " samples)'\nunset key\nset grid\n"
    // Readable ticks in small panels: three significant digits, the x ticks slanted.
    << "set format x '%.3g'\nset format y '%.3g'\nset xtics rotate by 30 right\n";
  for (int row = 0; row < d; ++row)
    for (int col = 0; col < d; ++col) {
      if (col > row) {
        g << "set multiplot next\n";
        continue;
      }
      g << "set xlabel '" << (row == d - 1 ? label(r, col) : "") << "'\n";
      g << "set xrange [" << lo[col] << ":" << hi[col] << "]\n";
      if (col == row) {
        g << "set ylabel '" << (col == 0 ? "density" : "") << "'\nset autoscale y\n"
          << "plot 'corner_marginals.csv' skip 1 using " << 2 * col + 1 << ":" << 2 * col + 2
          << " with boxes fs solid 0.5 lc rgb '#1f77b4'\n";
      } else {
        g << "set ylabel '" << (col == 0 ? label(r, row) : "") << "'\n"
          << "set yrange [" << lo[row] << ":" << hi[row] << "]\n"
          << "plot 'posterior_samples.csv' skip 1 using " << col + 1 << ":" << row + 1
          << " with points pt 7 ps 0.25 lc rgb '#1f77b4'\n";
      }
    }
  g << "unset multiplot\nset output\n";
  write_text_atomic((fs::path(dir) / "corner.gp").string(), g.str());
  run_gnuplot_to_png(dir, "corner.gp", (fs::path(dir) / "corner.png").string());
}

/// predictive.{csv,png} (`name` "predictive") or predictive_STEM.{csv,png} of one experiment.
void write_predictive(const InferenceResult& r, const InferenceResult::ExperimentFit& e,
                      const std::string& dir, const std::string& name) {
  CsvTable t;
  t.comments = {
      "posterior predictive of the model curve (no measurement noise) at the data's "
      "forces, and the data with the sigmas the likelihood used (before sigma-scale)",
      "method " + r.method + ", data " + e.path + " (" + e.data.name + ")",
      "sigma: " + sigma_text(e.data)};
  t.header = {"force_pN",
              "axial_q05_um",
              "axial_q50_um",
              "axial_q95_um",
              "transverse_q05_um",
              "transverse_q50_um",
              "transverse_q95_um",
              "data_axial_um",
              "data_axial_sigma_um",
              "data_transverse_um",
              "data_transverse_sigma_um"};
  for (size_t k = 0; k < e.axial_q50.size(); ++k)
    t.rows.push_back({e.data.force_pN[k], e.axial_q05[k], e.axial_q50[k], e.axial_q95[k],
                      e.transverse_q05[k], e.transverse_q50[k], e.transverse_q95[k],
                      e.data.axial_um[k], e.data.axial_sigma_um[k], e.data.transverse_um[k],
                      e.data.transverse_sigma_um[k]});
  const std::string csv = name + ".csv";
  write_csv((fs::path(dir) / csv).string(), t);
  PlotSpec p;
  p.title = "Posterior predictive (" + plain(r.method) + "): median and 90 % band of the model";
  p.xlabel = "force (pN)";
  p.ylabel = "diameter (µm)";
  p.key = "inside right center";
  const std::string band = "filledcurves fs transparent solid 0.25 noborder";
  // The data by their declared name (else file name), with the sigma the likelihood used.
  std::ostringstream extra;
  extra << std::setprecision(3) << e.data.extra_uncertainty_um();
  const std::string sigma =
      e.data.extra_uncertainty_um() > 0 ? " (error bar ⊕ " + extra.str() + " µm)" : " (error bar)";
  const std::string data = experiment_plot_label(e.data.name) + sigma;
  p.series = {{"D_{A} 90 % band", csv, "1:2:4", band, "#1f77b4"},
              {"D_{A} median", csv, "1:3", "lines", "#1f77b4"},
              {"D_{A} " + data, csv, "1:8:9", "yerrorbars", "#000000"},
              {"D_{T} 90 % band", csv, "1:5:7", band, "#d62728"},
              {"D_{T} median", csv, "1:6", "lines", "#d62728"},
              {"D_{T} " + data, csv, "1:10:11", "yerrorbars", "#555555", 5}};
  render_plot(p, dir, name);
}

void write_predictive(const InferenceResult& r, const std::string& dir) {
  InferenceResult::ExperimentFit e;
  e.path = r.data_file;
  e.data = r.data;
  e.axial_q05 = r.axial_q05;
  e.axial_q50 = r.axial_q50;
  e.axial_q95 = r.axial_q95;
  e.transverse_q05 = r.transverse_q05;
  e.transverse_q50 = r.transverse_q50;
  e.transverse_q95 = r.transverse_q95;
  write_predictive(r, e, dir, "predictive");
}
}  // namespace

void write_inference(const InferenceResult& r, const std::string& dir) {
  ensure_output_directory(dir);
  write_text_atomic((fs::path(dir) / "summary.json").string(), inference_json(r) + "\n");
  CsvTable s;
  s.comments = {"equally weighted posterior samples (" +
                std::string(r.sampler == "laplace-is"
                                ? "laplace-is, systematic resampling of the importance draws"
                                : "TMCMC, last stage") +
                "), natural units; mu, K in uN/m from the closed forms"};
  for (size_t k = 0; k < r.names.size(); ++k) s.header.push_back(r.names[k]);
  s.header.insert(s.header.end(), {"mu_uN_per_m", "K_uN_per_m", "log_likelihood"});
  const int n = static_cast<int>(r.samples.rows()), d = static_cast<int>(r.samples.cols());
  for (int i = 0; i < n; ++i) {
    std::vector<double> row;
    for (int k = 0; k < d; ++k) row.push_back(r.samples(i, k));
    row.insert(row.end(), {r.mu_uN_per_m(i), r.K_uN_per_m(i), r.log_likelihood(i)});
    s.rows.push_back(std::move(row));
  }
  write_csv((fs::path(dir) / "posterior_samples.csv").string(), s);
  {
    const std::string path = (fs::path(dir) / "posterior_samples.h5").string();
    TempFile tmp(path);  // removed on every path that does not commit it
    {
      H5File f = H5File::create(tmp.path(), path);
      std::vector<double> buf;
      for (const auto& row : s.rows) buf.insert(buf.end(), row.begin(), row.end());
      f.write("samples", buf.data(), n, s.header.size());
      std::string cols;
      for (const auto& h : s.header) cols += (cols.empty() ? "" : ",") + h;
      f.write_attribute("columns", cols);
      f.write_attribute("method", r.method);
      f.write_attribute("log_evidence", r.log_evidence);
      f.write_attribute("log_evidence_sd", r.log_evidence_sd);
      f.write_attribute("seed", static_cast<long long>(r.seed));
      f.close();
    }
    tmp.commit();
  }
  write_corner(r, dir);
  if (!r.axial_q50.empty()) write_predictive(r, dir);
  // Several experiments: each one's fit as well (predictive_STEM.{csv,png}).
  if (r.experiments.size() > 1)
    for (const auto& e : r.experiments)
      if (!e.axial_q50.empty()) write_predictive(r, e, dir, "predictive_" + e.stem);
}

}  // namespace rbc
