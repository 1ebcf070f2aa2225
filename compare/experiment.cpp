#include "compare/experiment.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

namespace rbc {

namespace {
const char* const kExperimentColumns[] = {"force_pN", "axial_um", "axial_err_um", "transverse_um",
                                          "transverse_err_um"};
constexpr int kExperimentColumnCount = 5;

std::vector<std::string> split_commas(const std::string& line) {
  std::vector<std::string> cells;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    std::string c =
        line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const size_t a = c.find_first_not_of(" \t"), b = c.find_last_not_of(" \t");
    cells.push_back(a == std::string::npos ? std::string() : c.substr(a, b - a + 1));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return cells;
}
}  // namespace

std::vector<ExperimentPoint> parse_experiment(std::istream& in, const std::string& name) {
  const auto fail = [&](int lineno, const std::string& what) {
    throw std::runtime_error("experiment file '" + name + "'" +
                             (lineno > 0 ? " line " + std::to_string(lineno) : std::string()) +
                             ": " + what);
  };
  std::vector<ExperimentPoint> out;
  std::string line;
  bool header = false;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos || line[0] == '#') continue;
    const std::vector<std::string> cells = split_commas(line);
    if (!header) {
      for (const char* col : kExperimentColumns) {
        bool found = false;
        for (const auto& c : cells) found = found || c == col;
        if (!found) fail(lineno, std::string("missing column '") + col + "'");
      }
      for (int k = 0; k < static_cast<int>(cells.size()); ++k)
        if (k >= kExperimentColumnCount || cells[k] != kExperimentColumns[k])
          fail(lineno, "unexpected column '" + cells[k] +
                           "' (expected force_pN,axial_um,axial_err_um,transverse_um,"
                           "transverse_err_um in this order)");
      header = true;
      continue;
    }
    if (static_cast<int>(cells.size()) != kExperimentColumnCount)
      fail(lineno, std::to_string(cells.size()) + " values, expected " +
                       std::to_string(kExperimentColumnCount));
    double v[kExperimentColumnCount];
    for (int k = 0; k < kExperimentColumnCount; ++k) {
      size_t used = 0;
      try {
        v[k] = std::stod(cells[k], &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (cells[k].empty() || used != cells[k].size() || !std::isfinite(v[k]))
        fail(lineno,
             std::string(kExperimentColumns[k]) + " '" + cells[k] + "' is not a finite number");
    }
    const ExperimentPoint p{v[0], v[1], v[2], v[3], v[4]};
    const auto value = [](double x) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%g", x);
      return std::string(buf);
    };
    if (p.force_pN < 0) fail(lineno, "force_pN " + value(p.force_pN) + " is negative");
    if (p.axial_um <= 0 || p.transverse_um <= 0)
      fail(lineno, "diameter " + value(p.axial_um <= 0 ? p.axial_um : p.transverse_um) +
                       " um is not positive");
    if (!(p.axial_err_um > 0))
      fail(lineno, "axial_err_um " + value(p.axial_err_um) + " is not a positive error bar");
    if (!(p.transverse_err_um > 0))
      fail(lineno,
           "transverse_err_um " + value(p.transverse_err_um) + " is not a positive error bar");
    if (!out.empty() && !(p.force_pN > out.back().force_pN))
      fail(lineno, "force_pN " + value(p.force_pN) + " does not increase (previous " +
                       value(out.back().force_pN) + ")");
    out.push_back(p);
  }
  if (!header) fail(0, "has no header line");
  if (out.empty()) fail(0, "has no data rows");
  return out;
}

std::vector<ExperimentPoint> load_experiment(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open experiment file '" + path + "'");
  return parse_experiment(in, path);
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
