// SPDX-License-Identifier: GPL-3.0-or-later
#include "compare/experiment.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <utility>

#include "core/io.hpp"
#include "core/validation.hpp"

namespace rbc {

namespace {
std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}
}  // namespace

namespace {
std::vector<ExperimentPoint> experiment_points(const CsvTable& t, const std::string& path) {
  const std::vector<std::string> expected = {"force_pN", "axial_um", "axial_err_um",
                                             "transverse_um", "transverse_err_um"};
  auto bad = [&](const std::string& what) {
    return std::runtime_error("experiment file '" + path + "' " + what);
  };
  if (t.header != expected)
    throw bad("must have columns force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um");
  std::vector<ExperimentPoint> out;
  for (const auto& r : t.rows) {
    const std::string row = "data row " + std::to_string(out.size() + 1) + ": ";
    auto require = [&](std::size_t column, bool ok, const std::string& expectation) {
      if (!ok || !std::isfinite(r[column]))
        throw bad(row + expected[column] + " " + number(r[column]) + " is not " + expectation);
    };
    require(0, r[0] >= 0, "finite and >= 0");
    for (std::size_t c = 1; c < expected.size(); ++c) require(c, r[c] > 0, "finite and > 0");
    if (!out.empty())
      require(
          0, r[0] > out.back().force_pN,
          "above the previous row's " + number(out.back().force_pN) + " (forces must increase)");
    out.push_back({r[0], r[1], r[2], r[3], r[4]});
  }
  if (out.empty()) throw bad("has no data rows");
  return out;
}

/// The declarations among the comment lines (parse_csv strips the leading "# ").
void read_declarations(const std::vector<std::string>& comments, ExperimentFile& f) {
  // "key: value": key of [a-z][a-z0-9_]*, blanks (space, tab) around the value dropped.
  auto declaration =
      [](const std::string& c) -> std::optional<std::pair<std::string, std::string>> {
    const std::size_t colon = c.find(':');
    if (colon == 0 || colon == std::string::npos || c[0] < 'a' || c[0] > 'z') return std::nullopt;
    for (std::size_t i = 1; i < colon; ++i)
      if (!((c[i] >= 'a' && c[i] <= 'z') || (c[i] >= '0' && c[i] <= '9') || c[i] == '_'))
        return std::nullopt;
    const std::size_t first = c.find_first_not_of(" \t", colon + 1);
    if (first == std::string::npos) return std::pair{c.substr(0, colon), std::string()};
    const std::size_t last = c.find_last_not_of(" \t");
    return std::pair{c.substr(0, colon), c.substr(first, last + 1 - first)};
  };
  auto bad = [&](const std::string& what) {
    return std::runtime_error("experiment file '" + f.path + "' " + what);
  };
  bool have_name = false, have_extra = false;
  for (const std::string& c : comments) {
    const auto kv = declaration(c);
    if (!kv) continue;
    const auto& [key, value] = *kv;
    if (key == "name") {
      if (have_name) throw bad("declares 'name' twice");
      if (value.empty()) throw bad("declares an empty 'name'");
      f.name = value;
      have_name = true;
    } else if (key == "extra_uncertainty_um") {
      if (have_extra) throw bad("declares 'extra_uncertainty_um' twice");
      const std::optional<double> v = parse_number(value);
      if (!v || !std::isfinite(*v) || *v < 0)
        throw bad("declares extra_uncertainty_um '" + printable(value) +
                  "': expected a finite number >= 0 (um)");
      f.extra_uncertainty_um = *v;
      have_extra = true;
    } else if (key.find("uncertainty") != std::string::npos) {
      throw bad("declares '" + key +
                "', which is not a declaration: the extra uncertainty is declared as "
                "'# extra_uncertainty_um: VALUE' (um)");
    }
  }
}
}  // namespace

std::vector<ExperimentPoint> parse_experiment(std::istream& in, const std::string& path) {
  return parse_experiment_file(in, path).points;
}

std::vector<ExperimentPoint> load_experiment(const std::string& path) {
  return load_experiment_file(path).points;
}

ExperimentFile parse_experiment_file(std::istream& in, const std::string& path) {
  const CsvTable t = parse_csv(in, path);
  ExperimentFile f;
  f.path = path;
  read_declarations(t.comments, f);
  f.points = experiment_points(t, path);
  return f;
}

ExperimentFile load_experiment_file(const std::string& path) {
  check_csv_file(path);
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open CSV file '" + path + "'");
  return parse_experiment_file(in, path);
}

std::string ExperimentFile::label() const {
  return name.empty() ? std::filesystem::path(path).filename().string() : name;
}

std::string experiment_plot_label(const std::string& label) {
  // plot_literal (compare/plot.hpp) and the quote; written out here so that the data reader
  // links alone (fuzz/CMakeLists.txt).
  std::string text;
  for (const char c : label) {
    if (c == '\'') {
      text += "’";
      continue;
    }
    if (c == '_' || c == '^' || c == '{' || c == '}' || c == '@' || c == '&' || c == '~')
      text += '\\';
    text += c;
  }
  // A unit written "um" in a name is shown as µm (the house style).
  for (std::size_t at = find_word(text, "um"); at != std::string::npos;
       at = find_word(text, "um", at + 1))
    text.replace(at, 2, "µm");
  return text;
}

std::string default_data_directory() {
  if (const char* env = std::getenv("RBC_DATA_DIR")) return env;
  return RBC_DEFAULT_DATA_DIR;
}

namespace {
CurveSample interpolate(const std::vector<CurveSample>& m, double f) {
  auto hi = std::lower_bound(m.begin(), m.end(), f,
                             [](const CurveSample& s, double v) { return s.force_pN < v; });
  if (hi == m.end() || (hi == m.begin() && hi->force_pN > f + 1e-12))
    throw std::invalid_argument("model curve does not cover the experimental force " +
                                std::to_string(f) + " pN");
  if (std::abs(hi->force_pN - f) < 1e-12 || hi == m.begin()) return *hi;
  const auto lo = hi - 1;
  const double w = (f - lo->force_pN) / (hi->force_pN - lo->force_pN);
  return {f, lo->axial_um + w * (hi->axial_um - lo->axial_um),
          lo->transverse_um + w * (hi->transverse_um - lo->transverse_um)};
}
}  // namespace

FitQuality fit_quality(const std::vector<ExperimentPoint>& e, const std::vector<CurveSample>& m) {
  FitQuality q;
  double sa = 0, st = 0;
  for (const auto& p : e) {
    const CurveSample s = interpolate(m, p.force_pN);
    const double da = s.axial_um - p.axial_um, dt = s.transverse_um - p.transverse_um;
    sa += da * da;
    st += dt * dt;
    q.axial_inside += std::abs(da) <= p.axial_err_um;
    q.transverse_inside += std::abs(dt) <= p.transverse_err_um;
    ++q.points;
  }
  q.axial_rms_um = std::sqrt(sa / q.points);
  q.transverse_rms_um = std::sqrt(st / q.points);
  return q;
}

}  // namespace rbc
