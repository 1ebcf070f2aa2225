// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/likelihood.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <fstream>
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

double shared_offset_log_density(std::span<const double> r, std::span<const double> s,
                                 double tau_um) {
  if (r.size() != s.size())
    throw std::invalid_argument("shared_offset_log_density: " + std::to_string(r.size()) +
                                " residuals for " + std::to_string(s.size()) + " sigmas");
  if (!(tau_um >= 0)) throw std::invalid_argument("tau must be >= 0 um");
  const double t = tau_um * tau_um;
  double quad = 0, w_sum = 0, a = 0, log_det = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    if (!(s[i] > 0)) throw std::invalid_argument("sigma must be > 0 um");
    const double w = 1 / (s[i] * s[i]);
    quad += w * r[i] * r[i];
    w_sum += w;
    a += w * r[i];
    log_det += 2 * std::log(s[i]);
  }
  // Sherman-Morrison and the matrix determinant lemma for diag(s^2) + t 1 1'.
  quad -= t * a * a / (1 + t * w_sum);
  log_det += std::log1p(t * w_sum);
  return -0.5 * (quad + log_det + static_cast<double>(r.size()) * std::log(2 * M_PI));
}

double gaussian_log_likelihood(const DiameterData& d, const ModelDiameters& m, double c,
                               double tau_um) {
  if (tau_um == 0) return gaussian_log_likelihood(d, m, c);
  if (static_cast<int>(m.axial_um.size()) != d.size() ||
      static_cast<int>(m.transverse_um.size()) != d.size())
    throw std::invalid_argument("model diameters at " + std::to_string(m.axial_um.size()) +
                                " forces for " + std::to_string(d.size()) + " data points");
  if (!(c > 0)) throw std::invalid_argument("sigma scale must be > 0, got " + std::to_string(c));
  std::vector<double> ra, sa, rt, st;
  for (int k = 0; k < d.size(); ++k) {
    ra.push_back(m.axial_um[k] - d.axial_um[k]);
    sa.push_back(c * d.axial_sigma_um[k]);
    if (d.transverse_used[k]) {
      rt.push_back(m.transverse_um[k] - d.transverse_um[k]);
      st.push_back(c * d.transverse_sigma_um[k]);
    }
  }
  return shared_offset_log_density(ra, sa, tau_um) + shared_offset_log_density(rt, st, tau_um);
}

GaussianBlockGradient gaussian_block_gradient(std::span<const double> r,
                                              std::span<const double> sigma,
                                              std::span<const double> jac, int slots, double c,
                                              double tau_um) {
  const int n = static_cast<int>(r.size());
  if (static_cast<int>(sigma.size()) != n || static_cast<int>(jac.size()) != n * slots)
    throw std::invalid_argument("gaussian_block_gradient: inconsistent sizes");
  GaussianBlockGradient g;
  g.gradient.assign(slots, 0.0);
  g.information.assign(static_cast<size_t>(slots) * slots, 0.0);
  if (n == 0) return g;
  std::vector<double> s(n);
  for (int i = 0; i < n; ++i) s[i] = c * sigma[i];
  g.log_density = shared_offset_log_density(r, s, tau_um);
  const double t = tau_um * tau_um;
  // Unscaled weights u = 1/sigma^2 and their sums; w = u / c^2.
  double U = 0, A = 0, S = 0;
  for (int i = 0; i < n; ++i) {
    const double u = 1 / (sigma[i] * sigma[i]);
    U += u;
    A += u * r[i];
    S += u * r[i] * r[i];
  }
  const double c2 = c * c, gg = c2 + t * U;
  // f = -1/2 [S/c^2 - t A^2/(c^2 g) + 2(n-1) log c + log g + const], g = c^2 + t U.
  const double df_dt = -0.5 * (-A * A / (gg * gg) + U / gg);
  g.d_tau = 2 * tau_um * df_dt;
  g.d_scale = -0.5 * (-2 * S / (c2 * c) + 2 * t * A * A * (gg + c2) / (c2 * c * gg * gg) +
                      2.0 * (n - 1) / c + 2 * c / gg);
  // Sigma^-1 r and Sigma^-1 J by Sherman-Morrison: w o x - t (w'x) w / (1 + t W).
  const Eigen::Map<const Eigen::MatrixXd> J(jac.data(), n, slots);
  Eigen::VectorXd w(n), rv(n);
  for (int i = 0; i < n; ++i) {
    w(i) = 1 / (s[i] * s[i]);
    rv(i) = r[i];
  }
  const double denom = 1 + t * w.sum();
  const Eigen::VectorXd sinv_r = w.cwiseProduct(rv) - (t * w.dot(rv) / denom) * w;
  const Eigen::MatrixXd sinv_j = w.asDiagonal() * J - (t / denom) * w * (w.transpose() * J);
  const Eigen::VectorXd grad = -J.transpose() * sinv_r;
  const Eigen::MatrixXd info = J.transpose() * sinv_j;
  for (int k = 0; k < slots; ++k) g.gradient[k] = grad(k);
  for (int k = 0; k < slots * slots; ++k) g.information[k] = info.data()[k];
  // Variance parameters: 1/2 tr(Sigma^-1 dSigma_a Sigma^-1 dSigma_b), dense (n is small).
  Eigen::MatrixXd sigma_m = Eigen::MatrixXd::Constant(n, n, t);
  for (int i = 0; i < n; ++i) sigma_m(i, i) += s[i] * s[i];
  const Eigen::MatrixXd sinv = sigma_m.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
  Eigen::MatrixXd d_c = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) d_c(i, i) = 2 * s[i] * s[i] / c;
  const Eigen::MatrixXd d_t = Eigen::MatrixXd::Constant(n, n, 2 * tau_um);
  const Eigen::MatrixXd a = sinv * d_c, b = sinv * d_t;
  g.info_scale = 0.5 * (a * a).trace();
  g.info_tau = 0.5 * (b * b).trace();
  g.info_scale_tau = 0.5 * (a * b).trace();
  return g;
}

std::string to_string(DataKind k) {
  return k == DataKind::recovery ? "recovery" : "stretch";
}

DataKind detect_data_kind(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("data file '" + path + "' cannot be read");
  std::string line;
  while (std::getline(in, line)) {
    line.erase(std::remove_if(line.begin(), line.end(),
                              [](char ch) { return ch == ' ' || ch == '\t' || ch == '\r'; }),
               line.end());
    if (line.empty() || line[0] == '#') continue;
    return line.rfind("cell,time_s,length_over_width", 0) == 0 ? DataKind::recovery
                                                               : DataKind::stretch;
  }
  return DataKind::stretch;  // no header: parse_experiment names what is missing
}

}  // namespace rbc
