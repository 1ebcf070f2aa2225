// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/likelihood.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "calibrate/forward_model.hpp"

namespace rbc {

int DiameterData::terms() const {
  int t = size();
  for (char u : transverse_used) t += u;
  return t;
}

double DiameterData::extra_uncertainty_um() const {
  return std::hypot(declared_extra_uncertainty_um, added_extra_uncertainty_um);
}

DiameterData make_diameter_data(const std::vector<ExperimentPoint>& points, double extra_um) {
  if (!(extra_um >= 0) || !std::isfinite(extra_um))
    throw std::invalid_argument("extra uncertainty must be finite and >= 0 um, got " +
                                std::to_string(extra_um));
  if (points.empty()) throw std::invalid_argument("no data points");
  DiameterData d;
  d.smallest_error_bar_um = INFINITY;
  for (const auto& p : points) {
    d.force_pN.push_back(p.force_pN);
    d.axial_um.push_back(p.axial_um);
    d.axial_sigma_um.push_back(std::hypot(p.axial_err_um, extra_um));
    d.transverse_um.push_back(p.transverse_um);
    d.transverse_sigma_um.push_back(std::hypot(p.transverse_err_um, extra_um));
    d.transverse_used.push_back(p.force_pN > 0);
    d.smallest_error_bar_um = std::min(d.smallest_error_bar_um, p.axial_err_um);
    if (p.force_pN > 0)
      d.smallest_error_bar_um = std::min(d.smallest_error_bar_um, p.transverse_err_um);
  }
  // hypot(err, 0) = err exactly: without an extra uncertainty the sigmas are the error bars.
  d.added_extra_uncertainty_um = extra_um;
  return d;
}

DiameterData make_diameter_data(const ExperimentFile& file, double added_um) {
  if (!(added_um >= 0) || !std::isfinite(added_um))
    throw std::invalid_argument("--extra-uncertainty must be finite and >= 0 um, got " +
                                std::to_string(added_um));
  DiameterData d = make_diameter_data(file.points, std::hypot(file.extra_uncertainty_um, added_um));
  d.name = file.label();
  d.declared_extra_uncertainty_um = file.extra_uncertainty_um;
  d.added_extra_uncertainty_um = added_um;
  return d;
}

void check_data_forces(const std::vector<ExperimentPoint>& points, MethodKind kind,
                       const std::string& source) {
  for (std::size_t k = 0; k < points.size(); ++k) {
    try {
      validate_method_force(kind, points[k].force_pN);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("experiment file '" + source + "' data row " +
                                  std::to_string(k + 1) + ": " + e.what());
    }
  }
}

DiameterData load_diameter_data(const std::string& path, double added_um, MethodKind kind) {
  const ExperimentFile file = load_experiment_file(path);
  check_data_forces(file.points, kind, path);
  return make_diameter_data(file, added_um);
}

double gaussian_log_likelihood(const DiameterData& d, const ModelDiameters& m, double c) {
  if (static_cast<int>(m.axial_um.size()) != d.size() ||
      static_cast<int>(m.transverse_um.size()) != d.size())
    throw std::invalid_argument("model diameters at " + std::to_string(m.axial_um.size()) +
                                " forces for " + std::to_string(d.size()) + " data points");
  if (!(c > 0)) throw std::invalid_argument("sigma scale must be > 0, got " + std::to_string(c));
  const double log_sqrt_2pi = 0.5 * std::log(2 * M_PI);
  double l = 0;
  auto term = [&](double model, double data, double sigma) {
    const double s = c * sigma, r = (model - data) / s;
    l += -0.5 * r * r - std::log(s) - log_sqrt_2pi;
  };
  for (int k = 0; k < d.size(); ++k) {
    term(m.axial_um[k], d.axial_um[k], d.axial_sigma_um[k]);
    if (d.transverse_used[k])
      term(m.transverse_um[k], d.transverse_um[k], d.transverse_sigma_um[k]);
  }
  return l;
}

}  // namespace rbc
