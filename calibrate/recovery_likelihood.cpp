// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/recovery_likelihood.hpp"

#include <omp.h>

#include <gsl/gsl_integration.h>
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <unsupported/Eigen/LevenbergMarquardt>

#include "calibrate/smooth_patch.hpp"
#include "continuum/continuum_model.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/dynamics.hpp"
#include "core/cpu_time.hpp"
#include "core/fnv1a.hpp"
#include "core/io.hpp"
#include "core/units.hpp"
#include "core/validation.hpp"
#include "discrete/dynamics.hpp"
#include "homogenise/invariant_laws.hpp"
#include "homogenise/moduli.hpp"

namespace rbc {

// ---------------------------------------------------------------------------------------------
// Data

int RecoveryData::points() const {
  int n = 0;
  for (const auto& c : cells) n += static_cast<int>(c.time_s.size());
  return n;
}

namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::vector<std::string> split_commas(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::stringstream ss(line);
  while (std::getline(ss, cell, ',')) cells.push_back(trim(cell));
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

}  // namespace

RecoveryData read_recovery_data(const std::string& path) {
  const std::string file_quantity = "recovery data file '" + path + "'";
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InvalidParameter(file_quantity, "(unreadable)", "a readable CSV file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  RecoveryData data;
  data.path = path;
  Fnv1a hash;
  hash.add(text.data(), text.size());
  data.content_hash = hex_digits(hash.h);

  std::istringstream lines(text);
  std::string line;
  int lineno = 0;
  int columns = 0;  // 3: cell,time_s,length_over_width; 2: time_s,length_over_width
  std::vector<int> finished_ids;
  const auto at_line = [&](int n) { return file_quantity + " line " + std::to_string(n); };
  while (std::getline(lines, line)) {
    ++lineno;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    const std::vector<std::string> cells = split_commas(t);
    if (columns == 0) {
      if (cells == std::vector<std::string>{"cell", "time_s", "length_over_width"})
        columns = 3;
      else if (cells == std::vector<std::string>{"time_s", "length_over_width"})
        columns = 2;
      else
        throw InvalidParameter(at_line(lineno), "'" + printable(t) + "'",
                               "the header cell,time_s,length_over_width or "
                               "time_s,length_over_width");
      continue;
    }
    if (static_cast<int>(cells.size()) != columns)
      throw InvalidParameter(at_line(lineno), "'" + printable(t) + "'",
                             std::to_string(columns) + " comma-separated numbers");
    std::vector<double> v;
    for (const std::string& c : cells) {
      const std::optional<double> x = parse_finite_number(c);
      if (!x) throw InvalidParameter(at_line(lineno), "'" + printable(c) + "'", "a finite number");
      v.push_back(*x);
    }
    int id = 1;
    if (columns == 3) {
      if (!(v[0] >= 1 && v[0] <= 1e6 && v[0] == std::floor(v[0])))
        throw InvalidParameter(at_line(lineno) + " cell", format_number(v[0]),
                               "a positive integer");
      id = static_cast<int>(v[0]);
    }
    const double time = v[columns - 2], ratio = v[columns - 1];
    if (time < 0)
      throw InvalidParameter(at_line(lineno) + " time_s", format_number(time), ">= 0", "s");
    if (!(ratio > 0))
      throw InvalidParameter(at_line(lineno) + " length_over_width", format_number(ratio), "> 0");
    if (data.cells.empty() || data.cells.back().id != id) {
      if (std::find(finished_ids.begin(), finished_ids.end(), id) != finished_ids.end())
        throw InvalidParameter(
            at_line(lineno) + " cell", std::to_string(id),
            "the rows of each cell together (cell " + std::to_string(id) + " appeared before)");
      if (!data.cells.empty()) finished_ids.push_back(data.cells.back().id);
      data.cells.push_back(RecoveryCell{id, {}, {}});
    }
    RecoveryCell& cell = data.cells.back();
    if (!cell.time_s.empty() && !(time > cell.time_s.back()))
      throw InvalidParameter(
          at_line(lineno) + " time_s", format_number(time),
          "greater than the cell's previous time " + format_number(cell.time_s.back()), "s");
    cell.time_s.push_back(time);
    cell.length_over_width.push_back(ratio);
  }
  if (columns == 0)
    throw InvalidParameter(file_quantity, "(no header)",
                           "the header cell,time_s,length_over_width or time_s,length_over_width "
                           "followed by data rows");
  if (data.cells.empty())
    throw InvalidParameter(file_quantity, "(no data rows)", "at least one cell of 3 points");
  for (const RecoveryCell& c : data.cells)
    if (c.time_s.size() < 3)
      throw InvalidParameter(file_quantity + " cell " + std::to_string(c.id),
                             std::to_string(c.time_s.size()) + " points", "at least 3 points");
  return data;
}

// ---------------------------------------------------------------------------------------------
// The release scene

void RecoveryModelOptions::validate() const {
  require_integer_in_range("elements", elements, kMinContinuumElements, kMaxContinuumElements);
  require_finite_in_range("reference viscosity eta_ref", "pN s/um", eta_ref_pN_s_per_um, 0,
                          kUnbounded);
  require_finite_in_range("dilatational ratio eta_d/eta_m", "", dilatational_ratio, 0, kUnbounded,
                          Ends::closed_open);
  require_finite_in_range("release force", "pN", release_force_pN, 0, kMaxContinuumForce_pN);
  require_finite_in_range("duration", "s", duration_s, 0, kUnbounded);
  require_finite_in_range("time step dt", "s", dt_s, 0, duration_s);
  require_finite_in_range("step tolerance", "pN/s", step_tolerance_pN_per_s, 0, kUnbounded);
}

RecoveryModel::RecoveryModel(const RecoveryModelOptions& options) : options_(options) {
  options_.validate();
  // The rest mesh is assembled by OpenMP reductions: built on one thread so that the curves do
  // not depend on OMP_NUM_THREADS (as the forward model's).
  const int saved_threads = omp_get_max_threads();
  omp_set_num_threads(1);
  struct Restore {
    int n;
    ~Restore() { omp_set_num_threads(n); }
  } restore{saved_threads};
  mesh_ = make_continuum_mesh(options_.elements);
}

namespace {

/// lambda = D_A/D_T at every sample of one backward-Euler trajectory at F = 0 from `start`.
struct Track {
  std::vector<double> t_s, lambda;
  bool converged = false;
  std::string status;
  int halved_steps = 0;
};

Track release_trajectory(const ContinuumModel& model, const DynamicsState& start,
                         const RecoveryModelOptions& o, double dt_s, double duration_s) {
  ContinuumDynamicsOptions dop;
  dop.shear_viscosity_pN_s_per_um = o.eta_ref_pN_s_per_um;
  dop.dilatational_ratio = o.dilatational_ratio;
  dop.tolerance_pN_per_s = o.step_tolerance_pN_per_s;
  ContinuumDynamics dyn(model, dop);
  TrajectoryOptions to;
  to.duration_s = duration_s;
  to.dt_s = dt_s;
  to.sample_every = 1;
  const TrajectoryResult r =
      run_trajectory([&](double h, DynamicsState& s) { return dyn.step(0.0, h, s); },
                     [&](const DynamicsState& s) { return dyn.measure(0.0, s); }, start, to);
  Track out;
  out.converged = r.converged;
  out.status = r.status;
  out.halved_steps = r.halved_steps;
  for (const TrajectorySample& s : r.samples) {
    out.t_s.push_back(s.t_s);
    out.lambda.push_back(s.axial_um / s.transverse_um);
  }
  return out;
}

/// Samples kept in the curve: down to g = kShapeFloor (below it log g is the solver's noise;
/// lambda then differs from lambda_inf by ~1e-3 r0 lambda_inf, far below any reading error).
constexpr double kShapeFloor = 1e-3;

/// Slope of the parabola through (x0,y0), (x1,y1), (x2,y2) at x = at.
double parabola_slope(double x0, double y0, double x1, double y1, double x2, double y2, double at) {
  const double d01 = (y1 - y0) / (x1 - x0), d12 = (y2 - y1) / (x2 - x1);
  const double c = (d12 - d01) / (x2 - x0);  // second divided difference
  return d01 + c * ((at - x0) + (at - x1));
}

}  // namespace

RecoveryCurve RecoveryModel::simulate(const ForwardParameters& p) const {
  p.validate();
  const double cpu0 = thread_cpu_seconds();
  const RecoveryModelOptions& o = options_;
  RecoveryCurve curve;
  curve.eta_ref_pN_s_per_um = o.eta_ref_pN_s_per_um;
  WlcParameters wlc;  // Lbar = 75 nm, T = 300 K
  wlc.persistence_um = units::nm_to_um(p.persistence_nm);
  wlc.lmax_um = units::nm_to_um(p.lmax_nm);
  curve.shear_modulus_pN_per_um = closed_form_moduli(wlc, StericParameters{}).mu_pN_per_um;
  ContinuumParameters cp;
  cp.bending.kappa_pNum = units::joule_to_pNum(p.kappa_J);
  ContinuumModel model =
      build_continuum_model(mesh_, make_membrane_law(wlc, StericParameters{}, o.order), cp);
  model.patch = smooth_tweezer_patch(model.rest, model.topo, p.contact_fraction);

  ContinuumOptions co;
  co.element_fields = false;
  const auto pts = run_continuum_stretch(model, {0.0, o.release_force_pN}, co);
  if (!pts[0].converged || !pts[1].converged) {
    curve.status =
        "static equilibrium at " + format_number(pts[0].converged ? o.release_force_pN : 0.0) +
        " pN did not converge: " + to_string(pts[0].converged ? pts[1].status : pts[0].status);
    curve.cpu_s = thread_cpu_seconds() - cpu0;
    return curve;
  }
  curve.lambda_inf = pts[0].axial_um / pts[0].transverse_um;
  const DynamicsState start{pts[1].x, pts[1].multipliers};
  // A whole number of coarse steps, so both runs of the extrapolation share their grid.
  const double coarse = o.richardson ? 2 * o.dt_s : o.dt_s;
  const double duration = coarse * std::ceil(o.duration_s / coarse - 1e-9);
  const Track fine = release_trajectory(model, start, o, o.dt_s, duration);
  Track used = fine;
  if (fine.converged && o.richardson) {
    const Track crude = release_trajectory(model, start, o, coarse, duration);
    used.converged = crude.converged;
    used.halved_steps += crude.halved_steps;
    used.status = crude.status;
    used.t_s.clear();
    used.lambda.clear();
    for (size_t k = 0; k < crude.t_s.size(); ++k) {
      if (2 * k >= fine.t_s.size() || std::abs(fine.t_s[2 * k] - crude.t_s[k]) > 1e-9 * coarse)
        break;
      used.t_s.push_back(crude.t_s[k]);
      used.lambda.push_back(2 * fine.lambda[2 * k] - crude.lambda[k]);
    }
  }
  curve.halved_steps = used.halved_steps;
  curve.converged = used.converged && used.t_s.size() >= 3;
  curve.status = curve.converged  ? "converged"
                 : used.converged ? "fewer than 3 samples"
                                  : used.status;
  if (!curve.converged) {
    curve.cpu_s = thread_cpu_seconds() - cpu0;
    return curve;
  }
  const double linf = curve.lambda_inf;
  const double r0 = (used.lambda[0] - linf) / (used.lambda[0] + linf);
  if (!(std::abs(r0) > 1e-9)) {
    curve.converged = false;
    curve.status = "no deformation to recover from (lambda(0) = lambda_inf)";
    curve.cpu_s = thread_cpu_seconds() - cpu0;
    return curve;
  }
  for (size_t k = 0; k < used.t_s.size(); ++k) {
    const double r = (used.lambda[k] - linf) / (used.lambda[k] + linf);
    const double g = r / r0;
    if (k > 0 && !(g >= kShapeFloor)) break;
    curve.time_s.push_back(used.t_s[k]);
    curve.shape.push_back(g);
    curve.lambda.push_back(used.lambda[k]);
  }
  if (curve.time_s.size() < 3) {
    curve.converged = false;
    curve.status =
        "the recovery fell below 1e-3 of its amplitude within 3 samples: use a smaller dt";
  }
  curve.cpu_s = thread_cpu_seconds() - cpu0;
  return curve;
}

RecoveryCurve simulate_recovery(const ForwardParameters& parameters,
                                const RecoveryModelOptions& options) {
  return RecoveryModel(options).simulate(parameters);
}

double RecoveryCurve::at(double t, double* g_prime) const {
  const size_t n = time_s.size();
  if (n < 3 || shape.size() != n)
    throw std::invalid_argument("recovery curve of " + std::to_string(n) +
                                " samples: at least 3 needed");
  // Knot slopes of y = log g: parabolas through neighbours (one-sided at the ends).
  const auto y = [&](size_t k) { return std::log(shape[k]); };
  const auto slope = [&](size_t k) {
    const size_t a = k == 0 ? 0 : (k == n - 1 ? n - 3 : k - 1);
    return parabola_slope(time_s[a], y(a), time_s[a + 1], y(a + 1), time_s[a + 2], y(a + 2),
                          time_s[k]);
  };
  const double tail_rate = std::min(0.0, slope(n - 1));
  if (t >= time_s[n - 1]) {
    const double v = shape[n - 1] * std::exp(tail_rate * (t - time_s[n - 1]));
    if (g_prime) *g_prime = tail_rate * v;
    return v;
  }
  const double tc = std::max(t, 0.0);
  const size_t k =
      static_cast<size_t>(std::upper_bound(time_s.begin(), time_s.end(), tc) - time_s.begin() - 1);
  const double h = time_s[k + 1] - time_s[k];
  const double s = (tc - time_s[k]) / h;
  const double m0 = slope(k) * h, m1 = (k + 1 == n - 1 ? tail_rate : slope(k + 1)) * h;
  const double y0 = y(k), y1 = y(k + 1);
  const double s2 = s * s, s3 = s2 * s;
  const double yv = (2 * s3 - 3 * s2 + 1) * y0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * y1 +
                    (s3 - s2) * m1;
  const double dy = ((6 * s2 - 6 * s) * y0 + (3 * s2 - 4 * s + 1) * m0 + (-6 * s2 + 6 * s) * y1 +
                     (3 * s2 - 2 * s) * m1) /
                    h;
  const double v = std::exp(yv);
  if (g_prime) *g_prime = t < 0 ? 0.0 : dy * v;
  return v;
}

double RecoveryCurve::recovery_time_s(double eta_m) const {
  if (!converged) return 0;
  const RecoveryFit f = fit_recovery(time_s, lambda, lambda_inf);
  return f.valid ? f.recovery_time_s * eta_m / eta_ref_pN_s_per_um : 0.0;
}

// ---------------------------------------------------------------------------------------------
// The likelihood

void RecoveryLikelihoodOptions::validate() const {
  require_finite_in_range("nuisance prior lambda_min", "", lambda_min, 0, kUnbounded);
  require_finite_in_range("nuisance prior lambda_max", "", lambda_max, lambda_min, kUnbounded,
                          Ends::open_open);
}

namespace {

constexpr double kLog2Pi = 1.8378770664093454836;

/// One cell at rescale s = eta_ref/eta_m: u_i = g(t_i s), du_i/ds = g'(t_i s) t_i.
struct CellProblem {
  const RecoveryCell* cell = nullptr;
  double sigma = 0.02;
  std::vector<double> u, du_ds;
};

// h(x) = (1 + x)/(1 - x) and its derivatives.
inline double h0(double x) {
  return (1 + x) / (1 - x);
}
inline double h1(double x) {
  return 2 / ((1 - x) * (1 - x));
}
inline double h2(double x) {
  return 4 / ((1 - x) * (1 - x) * (1 - x));
}

/// Residuals (lambda_model - lambda)/sigma in (alpha, beta) = (log lambda_inf, atanh r0).
struct CellFunctor : Eigen::DenseFunctor<double> {
  const CellProblem& c;
  explicit CellFunctor(const CellProblem& cp)
      : Eigen::DenseFunctor<double>(2, static_cast<int>(cp.u.size())), c(cp) {}
  int operator()(const InputType& x, ValueType& f) const {
    const double a = std::exp(x[0]), r0 = std::tanh(x[1]);
    for (int i = 0; i < values(); ++i)
      f[i] = (a * h0(r0 * c.u[i]) - c.cell->length_over_width[i]) / c.sigma;
    return 0;
  }
  int df(const InputType& x, JacobianType& j) const {
    const double a = std::exp(x[0]), r0 = std::tanh(x[1]);
    for (int i = 0; i < values(); ++i) {
      const double xi = r0 * c.u[i];
      j(i, 0) = a * h0(xi) / c.sigma;
      j(i, 1) = (1 - r0 * r0) * a * h1(xi) * c.u[i] / c.sigma;
    }
    return 0;
  }
};

struct CellSums {
  double phi = 0;                    ///< 1/2 sum e^2/sigma^2
  Eigen::Vector2d grad;              ///< dPhi/dnu, nu = (a, r0)
  Eigen::Matrix2d hess_gn;           ///< sum J J^T / sigma^2
  Eigen::Matrix2d hess;              ///< exact d2Phi/dnu2
  double dphi_ds = 0;                ///< partial dPhi/ds at fixed nu
  Eigen::Vector2d dgrad_ds;          ///< partial d(dPhi/dnu)/ds
  Eigen::Matrix2d dhgn_ds;           ///< partial d(hess_gn)/ds
  Eigen::Matrix2d dhgn_da, dhgn_dr;  ///< partial d(hess_gn)/da, /dr0
};

CellSums cell_sums(const CellProblem& c, double a, double r0) {
  CellSums s;
  s.grad.setZero();
  s.hess_gn.setZero();
  s.hess.setZero();
  s.dgrad_ds.setZero();
  s.dhgn_ds.setZero();
  s.dhgn_da.setZero();
  s.dhgn_dr.setZero();
  const double w = 1 / (c.sigma * c.sigma);
  for (size_t i = 0; i < c.u.size(); ++i) {
    const double u = c.u[i], x = r0 * u;
    const double e = a * h0(x) - c.cell->length_over_width[i];
    const Eigen::Vector2d J(h0(x), a * h1(x) * u);
    Eigen::Matrix2d d2;  // d2 lambda/dnu2
    d2 << 0, h1(x) * u, h1(x) * u, a * h2(x) * u * u;
    const Eigen::Vector2d dJ_du(h1(x) * r0, a * (h2(x) * r0 * u + h1(x)));
    const Eigen::Vector2d dJ_da(0, h1(x) * u), dJ_dr(h1(x) * u, a * h2(x) * u * u);
    const double dlam_ds = a * h1(x) * r0 * c.du_ds[i];
    const Eigen::Vector2d dJ_ds = dJ_du * c.du_ds[i];
    s.phi += 0.5 * w * e * e;
    s.grad += w * e * J;
    s.hess_gn += w * J * J.transpose();
    s.hess += w * (J * J.transpose() + e * d2);
    s.dphi_ds += w * e * dlam_ds;
    s.dgrad_ds += w * (dlam_ds * J + e * dJ_ds);
    s.dhgn_ds += w * (dJ_ds * J.transpose() + J * dJ_ds.transpose());
    s.dhgn_da += w * (dJ_da * J.transpose() + J * dJ_da.transpose());
    s.dhgn_dr += w * (dJ_dr * J.transpose() + J * dJ_dr.transpose());
  }
  return s;
}

/// Mode of the cell's nuisances and its log-likelihood term and d/ds.
RecoveryCellFit fit_cell(const CellProblem& c, const RecoveryLikelihoodOptions& o,
                         double& dterm_ds) {
  RecoveryCellFit fit;
  fit.id = c.cell->id;
  const auto& y = c.cell->length_over_width;
  const double ymin = *std::min_element(y.begin(), y.end());
  const int n = static_cast<int>(y.size());
  // Starts: lambda_inf just below the smallest reading, r0 from the first reading.
  double best_phi = std::numeric_limits<double>::infinity();
  Eigen::Vector2d best(0, 0);
  for (double shrink : {0.98, 0.9, 0.75}) {
    const double a = std::max(1e-3, shrink * ymin);
    const double r1 = (y[0] - a) / (y[0] + a);
    const double r0 = std::clamp(r1 / std::max(c.u[0], 1e-3), -0.95, 0.95);
    Eigen::VectorXd x(2);
    x << std::log(a), std::atanh(r0);
    CellFunctor f(c);
    Eigen::LevenbergMarquardt<CellFunctor> lm(f);
    lm.setXtol(1e-14);
    lm.setFtol(1e-14);
    lm.setGtol(0.0);
    lm.setMaxfev(400);
    lm.minimize(x);
    if (!x.allFinite()) continue;
    Eigen::VectorXd fv(n);
    f(x, fv);
    const double phi = 0.5 * fv.squaredNorm();
    if (phi < best_phi) {
      best_phi = phi;
      best = Eigen::Vector2d(x[0], x[1]);
    }
  }
  if (!std::isfinite(best_phi)) return fit;
  double a = std::exp(best[0]), r0 = std::tanh(best[1]);
  // Newton polish in (a, r0) on the exact Hessian: the envelope and implicit-function
  // derivatives below need the gradient at round-off.
  CellSums s = cell_sums(c, a, r0);
  for (int it = 0; it < 3; ++it) {
    Eigen::LLT<Eigen::Matrix2d> llt(s.hess);
    if (llt.info() != Eigen::Success) break;
    const Eigen::Vector2d step = -llt.solve(s.grad);
    const double a1 = a + step[0], r1 = r0 + step[1];
    if (!(a1 > 0 && std::abs(r1) < 1)) break;
    const CellSums s1 = cell_sums(c, a1, r1);
    if (!(s1.phi <= s.phi + 1e-12 * (1 + s.phi))) break;
    a = a1;
    r0 = r1;
    s = s1;
  }
  Eigen::LLT<Eigen::Matrix2d> exact(s.hess);
  const Eigen::LDLT<Eigen::Matrix2d> gn(s.hess_gn);
  fit.converged = exact.info() == Eigen::Success && gn.info() == Eigen::Success &&
                  s.hess_gn.determinant() > 0 && std::isfinite(s.phi);
  fit.lambda_inf = a;
  fit.r0 = r0;
  fit.lambda_0 = a * h0(r0);
  fit.chi2 = 2 * s.phi;
  const double gauss = -0.5 * n * (kLog2Pi + 2 * std::log(c.sigma));
  if (!fit.converged) {
    fit.log_term = -std::numeric_limits<double>::infinity();
    dterm_ds = 0;
    return fit;
  }
  if (o.nuisances == RecoveryNuisances::profile) {
    fit.log_term = gauss - s.phi;
    dterm_ds = -s.dphi_ds;  // envelope: the mode's motion does not change the maximum
    return fit;
  }
  // Laplace: log prior density of (a, r0) (uniform in (lambda_inf, lambda_0) over the box,
  // |d lambda_0/d r0| = 2a/(1 - r0)^2), + log 2pi - 1/2 log det H_GN.
  const double width = o.lambda_max - o.lambda_min;
  const double log_prior = std::log(2 * a / ((1 - r0) * (1 - r0))) - 2 * std::log(width);
  const Eigen::Matrix2d& H = s.hess_gn;
  fit.log_term = gauss - s.phi + log_prior + kLog2Pi - 0.5 * std::log(H.determinant());
  // d/ds: the mode moves as dnu/ds = -K^-1 d(grad)/ds (K the exact Hessian).
  const Eigen::Vector2d dnu = -exact.solve(s.dgrad_ds);
  const Eigen::Matrix2d dH = s.dhgn_ds + s.dhgn_da * dnu[0] + s.dhgn_dr * dnu[1];
  const double dlogdet = (H.inverse() * dH).trace();
  const double dlog_prior = dnu[0] / a + 2 * dnu[1] / (1 - r0);
  dterm_ds = -s.dphi_ds + dlog_prior - 0.5 * dlogdet;
  return fit;
}

/// Cell `cell` read on `curve` at rescale s = eta_ref/eta_m.
CellProblem cell_problem(const RecoveryCurve& curve, double s, const RecoveryCell& cell,
                         double sigma) {
  CellProblem c;
  c.cell = &cell;
  c.sigma = sigma;
  for (double t : cell.time_s) {
    double gp = 0;
    c.u.push_back(curve.at(t * s, &gp));
    c.du_ds.push_back(gp * t);
  }
  return c;
}

}  // namespace

RecoveryLikelihood evaluate_recovery_likelihood(const RecoveryCurve& curve, double eta_m,
                                                const RecoveryData& data,
                                                const RecoveryLikelihoodOptions& options) {
  options.validate();
  require_finite_in_range("membrane viscosity", "pN s/um", eta_m, 0, kUnbounded);
  require_finite_in_range("reading uncertainty sigma_ratio", "", data.sigma_ratio, 0, kUnbounded);
  RecoveryLikelihood out;
  if (!curve.converged) {
    out.log_likelihood = -std::numeric_limits<double>::infinity();
    return out;
  }
  const double s = curve.eta_ref_pN_s_per_um / eta_m;  // data time t is reference time t s
  double dlog_ds = 0;
  for (const RecoveryCell& cell : data.cells) {
    const CellProblem c = cell_problem(curve, s, cell, data.sigma_ratio);
    double dterm = 0;
    out.cells.push_back(fit_cell(c, options, dterm));
    out.log_likelihood += out.cells.back().log_term;
    dlog_ds += dterm;
  }
  // ds/d eta_m = -eta_ref/eta_m^2 = -s/eta_m.
  out.dlog_deta_per_pN_s_per_um = std::isfinite(out.log_likelihood) ? -dlog_ds * s / eta_m : 0.0;
  return out;
}

double recovery_log_likelihood(const RecoveryCurve& curve, double eta_m, const RecoveryData& data,
                               const RecoveryLikelihoodOptions& options) {
  return evaluate_recovery_likelihood(curve, eta_m, data, options).log_likelihood;
}

RecoveryGradient recovery_log_likelihood_gradient(const RecoveryModel& model,
                                                  const ForwardParameters& p, double eta_m,
                                                  const RecoveryData& data,
                                                  const RecoveryLikelihoodOptions& options,
                                                  double relative_step) {
  require_finite_in_range("relative step", "", relative_step, 0, 0.1);
  RecoveryGradient g;
  const RecoveryLikelihood centre =
      evaluate_recovery_likelihood(model.simulate(p), eta_m, data, options);
  g.log_likelihood = centre.log_likelihood;
  g.d_eta_per_pN_s_per_um = centre.dlog_deta_per_pN_s_per_um;
  g.converged = std::isfinite(centre.log_likelihood);
  const auto central = [&](double ForwardParameters::*field) {
    ForwardParameters lo = p, hi = p;
    const double h = relative_step * p.*field;
    lo.*field -= h;
    hi.*field += h;
    const double llo = recovery_log_likelihood(model.simulate(lo), eta_m, data, options);
    const double lhi = recovery_log_likelihood(model.simulate(hi), eta_m, data, options);
    if (!std::isfinite(llo) || !std::isfinite(lhi)) g.converged = false;
    return (lhi - llo) / (2 * h);
  };
  if (!g.converged) return g;
  g.d_persistence_per_nm = central(&ForwardParameters::persistence_nm);
  g.d_lmax_per_nm = central(&ForwardParameters::lmax_nm);
  g.d_kappa_per_J = central(&ForwardParameters::kappa_J);
  return g;
}

namespace {

/// The trajectories of a gradient: the centre, then (lo, hi) per differentiated parameter among
/// (p, Lmax, kappa), each on one thread of the calling thread's OpenMP team.
struct DifferenceRuns {
  std::vector<RecoveryCurve> curves;
  std::vector<int> which;  ///< parameter index (0..2) of each pair
  std::vector<double> steps;
};

DifferenceRuns difference_runs(const RecoveryModel& model, const ForwardParameters& p,
                               const std::array<bool, 3>& differentiate, double relative_step) {
  double ForwardParameters::*const fields[3] = {
      &ForwardParameters::persistence_nm, &ForwardParameters::lmax_nm, &ForwardParameters::kappa_J};
  DifferenceRuns out;
  std::vector<ForwardParameters> runs{p};
  for (int k = 0; k < 3; ++k) {
    if (!differentiate[k]) continue;
    const double h = relative_step * p.*fields[k];
    ForwardParameters lo = p, hi = p;
    lo.*fields[k] -= h;
    hi.*fields[k] += h;
    runs.push_back(lo);
    runs.push_back(hi);
    out.which.push_back(k);
    out.steps.push_back(h);
  }
  const int nr = static_cast<int>(runs.size());
  out.curves.resize(nr);
  // Each simulate() runs its solvers on one thread (its own scope), so the curves do not depend
  // on how the runs are spread over the team.
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < nr; ++i) out.curves[i] = model.simulate(runs[i]);
  return out;
}

/// One cell's Gauss-Newton information in (eta_m, p, Lmax, kappa) at eta_m with its nuisances
/// at `fit` (the Schur complement of recovery_gradient_and_information).
Eigen::Matrix4d cell_information(const DifferenceRuns& r, double eta_m, const RecoveryCell& cell,
                                 const RecoveryCellFit& fit, double sigma) {
  const double s = r.curves[0].eta_ref_pN_s_per_um / eta_m;
  const double w = 1 / (sigma * sigma);
  const double a = fit.lambda_inf, r0 = fit.r0;
  const int n = static_cast<int>(cell.time_s.size());
  Eigen::MatrixXd jt = Eigen::MatrixXd::Zero(n, 4), jn(n, 2);
  for (int i = 0; i < n; ++i) {
    const double t = cell.time_s[i];
    double gp = 0;
    const double u = r.curves[0].at(t * s, &gp), x = r0 * u;
    const double dlam_du = a * h1(x) * r0;
    jn(i, 0) = h0(x);
    jn(i, 1) = a * h1(x) * u;
    jt(i, 0) = dlam_du * gp * t * (-s / eta_m);
    for (size_t j = 0; j < r.which.size(); ++j) {
      const double du =
          (r.curves[2 + 2 * j].at(t * s) - r.curves[1 + 2 * j].at(t * s)) / (2 * r.steps[j]);
      jt(i, 1 + r.which[j]) = dlam_du * du;
    }
  }
  const Eigen::Matrix4d tt = w * jt.transpose() * jt;
  const Eigen::Matrix<double, 4, 2> tn = w * jt.transpose() * jn;
  const Eigen::Matrix2d nn = w * jn.transpose() * jn;
  return tt - tn * nn.ldlt().solve(tn.transpose());
}

}  // namespace

RecoveryGradientInformation recovery_gradient_and_information(
    const RecoveryModel& model, const ForwardParameters& p, double eta_m, const RecoveryData& data,
    const RecoveryLikelihoodOptions& options, const std::array<bool, 3>& differentiate,
    double relative_step) {
  require_finite_in_range("relative step", "", relative_step, 0, 0.1);
  options.validate();
  require_finite_in_range("membrane viscosity", "pN s/um", eta_m, 0, kUnbounded);
  const DifferenceRuns runs = difference_runs(model, p, differentiate, relative_step);
  const std::vector<RecoveryCurve>& curves = runs.curves;
  RecoveryGradientInformation out;
  out.trajectories = static_cast<int>(curves.size());
  RecoveryGradient& g = out.gradient;
  const RecoveryLikelihood centre = evaluate_recovery_likelihood(curves[0], eta_m, data, options);
  g.log_likelihood = centre.log_likelihood;
  g.d_eta_per_pN_s_per_um = centre.dlog_deta_per_pN_s_per_um;
  g.converged = std::isfinite(centre.log_likelihood);
  if (!g.converged) return out;
  double* const slots[3] = {&g.d_persistence_per_nm, &g.d_lmax_per_nm, &g.d_kappa_per_J};
  for (size_t j = 0; j < runs.which.size(); ++j) {
    const double llo = recovery_log_likelihood(curves[1 + 2 * j], eta_m, data, options);
    const double lhi = recovery_log_likelihood(curves[2 + 2 * j], eta_m, data, options);
    if (!std::isfinite(llo) || !std::isfinite(lhi)) g.converged = false;
    *slots[runs.which[j]] = (lhi - llo) / (2 * runs.steps[j]);
  }
  if (!g.converged) return out;
  // Gauss-Newton information, cell by cell at the nuisances' conditional mode.
  for (size_t c = 0; c < data.cells.size(); ++c)
    out.information +=
        cell_information(runs, eta_m, data.cells[c], centre.cells[c], data.sigma_ratio);
  out.information = 0.5 * (out.information + out.information.transpose()).eval();
  return out;
}

// ---------------------------------------------------------------------------------------------
// Cells with their own viscosity

namespace {

/// Gauss-Hermite rule for the weight exp(-z^2/2) (GSL: a = 0, b = 1/2); the weights sum to
/// sqrt(2 pi).
struct HermiteRule {
  std::vector<double> z, w;
};

HermiteRule hermite_rule(int n) {
  gsl_integration_fixed_workspace* ws = gsl_integration_fixed_alloc(
      gsl_integration_fixed_hermite, static_cast<size_t>(n), 0.0, 0.5, 0.0, 0.0);
  if (!ws) throw std::runtime_error("Gauss-Hermite rule of " + std::to_string(n) + " nodes");
  HermiteRule r;
  const double* z = gsl_integration_fixed_nodes(ws);
  const double* w = gsl_integration_fixed_weights(ws);
  r.z.assign(z, z + n);
  r.w.assign(w, w + n);
  gsl_integration_fixed_free(ws);
  return r;
}

/// One cell's term at viscosity eta and its derivative d/d eta (0 when not finite).
struct CellAtEta {
  double log_term = -std::numeric_limits<double>::infinity();
  double d_eta = 0;
  RecoveryCellFit fit;
};

CellAtEta cell_at_eta(const RecoveryCurve& curve, double eta, const RecoveryCell& cell,
                      double sigma, const RecoveryLikelihoodOptions& o) {
  CellAtEta out;
  if (!(eta > 0) || !std::isfinite(eta)) return out;
  const double s = curve.eta_ref_pN_s_per_um / eta;
  const CellProblem c = cell_problem(curve, s, cell, sigma);
  double dterm_ds = 0;
  out.fit = fit_cell(c, o, dterm_ds);
  out.log_term = out.fit.log_term;
  if (std::isfinite(out.log_term)) out.d_eta = -dterm_ds * s / eta;
  return out;
}

/// The integral of one cell over its own viscosity (RecoverySpreadLikelihood).
RecoverySpreadCell spread_cell(const RecoveryCurve& curve, double eta_m, double spread,
                               const RecoveryCell& cell, double sigma,
                               const RecoveryLikelihoodOptions& o, const HermiteRule& rule) {
  constexpr double kNegInf = -std::numeric_limits<double>::infinity();
  RecoverySpreadCell out;
  out.id = cell.id;
  const double m = std::log(eta_m);
  if (spread == 0) {  // the shared viscosity; d/ds = 0 by symmetry
    const CellAtEta a = cell_at_eta(curve, eta_m, cell, sigma, o);
    out.log_term = a.log_term;
    out.d_eta_per_pN_s_per_um = a.d_eta;
    out.eta_mode_pN_s_per_um = eta_m;
    return out;
  }
  const double sd = std::abs(spread), var = sd * sd;
  // f(v) = log L_c(e^v) + log N(v; m, s^2) up to a constant, v = log eta_c; f'(v) analytic.
  const auto f = [&](double v, double& fp) {
    const CellAtEta a = cell_at_eta(curve, std::exp(v), cell, sigma, o);
    if (!std::isfinite(a.log_term)) {
      fp = 0;
      return kNegInf;
    }
    fp = std::exp(v) * a.d_eta - (v - m) / var;
    return a.log_term - 0.5 * (v - m) * (v - m) / var;
  };
  // -f'' by a central difference of f' (step a thousandth of the current width); the prior's
  // 1/s^2 where the likelihood's curvature is not negative.
  double width = std::min(sd, 0.1);
  const auto curvature = [&](double v) {
    const double h = 1e-3 * width;
    double gp = 0, gm = 0;
    const double fp = f(v + h, gp), fm = f(v - h, gm);
    const double c = -(gp - gm) / (2 * h);
    return std::isfinite(fp) && std::isfinite(fm) && c > 0 ? c : 1 / var;
  };
  double v = m, g = 0;
  double fv = f(v, g);
  if (!std::isfinite(fv)) {
    out.log_term = kNegInf;
    return out;
  }
  // Newton on f', each step at most 1 in log eta and halved until f does not fall.
  for (int it = 0; it < 100; ++it) {
    const double c = curvature(v);
    width = 1 / std::sqrt(c);
    double step = std::clamp(g / c, -1.0, 1.0);
    double v1 = v, f1 = fv, g1 = g;
    bool moved = false;
    for (int half = 0; half < 40; ++half) {
      v1 = v + step;
      f1 = f(v1, g1);
      if (std::isfinite(f1) && f1 >= fv - 1e-12 * (1 + std::abs(fv))) {
        moved = true;
        break;
      }
      step *= 0.5;
    }
    if (!moved) break;
    v = v1;
    fv = f1;
    g = g1;
    if (std::abs(step) < 1e-9 * width) break;
  }
  width = 1 / std::sqrt(curvature(v));
  out.eta_mode_pN_s_per_um = std::exp(v);
  out.log_eta_sd = width;
  // Nodes v_k = v* + width z_k, i.e. eps_k = (v_k - m)/s; the integral over eps is
  // (width/s) sum_k w_k e^{z_k^2/2} L_c(eta_m e^{s eps_k}) phi(eps_k).
  const int n = static_cast<int>(rule.z.size());
  std::vector<double> l(n, kNegInf), d_eta(n, 0.0), d_s(n, 0.0);
  double top = kNegInf;
  for (int k = 0; k < n; ++k) {
    const double z = rule.z[k];
    const double vk = v + width * z;
    const double eps = (vk - m) / spread;
    const double eta_k = std::exp(vk);
    const CellAtEta a = cell_at_eta(curve, eta_k, cell, sigma, o);
    if (!std::isfinite(a.log_term)) continue;
    l[k] = std::log(rule.w[k]) + 0.5 * z * z + std::log(width / sd) + a.log_term - 0.5 * eps * eps -
           0.5 * kLog2Pi;
    d_eta[k] = a.d_eta * eta_k / eta_m;
    d_s[k] = a.d_eta * eta_k * eps;
    top = std::max(top, l[k]);
  }
  if (!std::isfinite(top)) {
    out.log_term = kNegInf;
    return out;
  }
  double sum = 0;
  for (int k = 0; k < n; ++k)
    if (std::isfinite(l[k])) sum += std::exp(l[k] - top);
  out.log_term = top + std::log(sum);
  for (int k = 0; k < n; ++k) {
    if (!std::isfinite(l[k])) continue;
    const double p = std::exp(l[k] - top) / sum;
    out.d_eta_per_pN_s_per_um += p * d_eta[k];
    out.d_spread += p * d_s[k];
  }
  return out;
}

}  // namespace

RecoverySpreadLikelihood evaluate_recovery_spread_likelihood(
    const RecoveryCurve& curve, double eta_m, double spread, const RecoveryData& data,
    const RecoveryLikelihoodOptions& options, int nodes) {
  options.validate();
  require_finite_in_range("membrane viscosity", "pN s/um", eta_m, 0, kUnbounded);
  require_finite_in_range("between-cell spread", "", spread, -kUnbounded, kUnbounded,
                          Ends::open_open);
  require_finite_in_range("reading uncertainty sigma_ratio", "", data.sigma_ratio, 0, kUnbounded);
  require_integer_in_range("Gauss-Hermite nodes", nodes, 1, 200);
  RecoverySpreadLikelihood out;
  if (!curve.converged) {
    out.log_likelihood = -std::numeric_limits<double>::infinity();
    return out;
  }
  const HermiteRule rule = hermite_rule(nodes);
  for (const RecoveryCell& cell : data.cells) {
    out.cells.push_back(spread_cell(curve, eta_m, spread, cell, data.sigma_ratio, options, rule));
    const RecoverySpreadCell& c = out.cells.back();
    out.log_likelihood += c.log_term;
    out.dlog_deta_per_pN_s_per_um += c.d_eta_per_pN_s_per_um;
    out.dlog_dspread += c.d_spread;
  }
  if (!std::isfinite(out.log_likelihood)) {
    out.log_likelihood = -std::numeric_limits<double>::infinity();
    out.dlog_deta_per_pN_s_per_um = out.dlog_dspread = 0;
  }
  return out;
}

double recovery_spread_log_likelihood(const RecoveryCurve& curve, double eta_m, double spread,
                                      const RecoveryData& data,
                                      const RecoveryLikelihoodOptions& options, int nodes) {
  return evaluate_recovery_spread_likelihood(curve, eta_m, spread, data, options, nodes)
      .log_likelihood;
}

RecoverySpreadGradientInformation recovery_spread_gradient_and_information(
    const RecoveryModel& model, const ForwardParameters& p, double eta_m, double spread,
    const RecoveryData& data, const RecoveryLikelihoodOptions& options,
    const std::array<bool, 3>& differentiate, double relative_step, int nodes) {
  require_finite_in_range("relative step", "", relative_step, 0, 0.1);
  options.validate();
  require_finite_in_range("membrane viscosity", "pN s/um", eta_m, 0, kUnbounded);
  require_finite_in_range("between-cell spread", "", spread, -kUnbounded, kUnbounded,
                          Ends::open_open);
  require_integer_in_range("Gauss-Hermite nodes", nodes, 1, 200);
  const DifferenceRuns runs = difference_runs(model, p, differentiate, relative_step);
  RecoverySpreadGradientInformation out;
  out.trajectories = static_cast<int>(runs.curves.size());
  RecoveryGradient& g = out.gradient;
  const RecoverySpreadLikelihood centre =
      evaluate_recovery_spread_likelihood(runs.curves[0], eta_m, spread, data, options, nodes);
  g.log_likelihood = centre.log_likelihood;
  g.d_eta_per_pN_s_per_um = centre.dlog_deta_per_pN_s_per_um;
  g.d_spread = centre.dlog_dspread;
  g.converged = std::isfinite(centre.log_likelihood);
  if (!g.converged) return out;
  double* const slots[3] = {&g.d_persistence_per_nm, &g.d_lmax_per_nm, &g.d_kappa_per_J};
  for (size_t j = 0; j < runs.which.size(); ++j) {
    const double llo =
        recovery_spread_log_likelihood(runs.curves[1 + 2 * j], eta_m, spread, data, options, nodes);
    const double lhi =
        recovery_spread_log_likelihood(runs.curves[2 + 2 * j], eta_m, spread, data, options, nodes);
    if (!std::isfinite(llo) || !std::isfinite(lhi)) g.converged = false;
    *slots[runs.which[j]] = (lhi - llo) / (2 * runs.steps[j]);
  }
  if (!g.converged) return out;
  // Fisher information of the Gaussian approximation, cell by cell (the header's formula).
  const double var = spread * spread;
  for (size_t c = 0; c < data.cells.size(); ++c) {
    const double eta_c = centre.cells[c].eta_mode_pN_s_per_um;
    const CellAtEta at =
        cell_at_eta(runs.curves[0], eta_c, data.cells[c], data.sigma_ratio, options);
    if (!std::isfinite(at.log_term)) {
      g.converged = false;
      return out;
    }
    Eigen::Matrix4d info = cell_information(runs, eta_c, data.cells[c], at.fit, data.sigma_ratio);
    info.row(0) *= eta_c;  // log eta_c's row and column
    info.col(0) *= eta_c;
    const Eigen::Vector4d ie = info.col(0);
    const double iee = ie[0];
    Eigen::Matrix4d mean = info - var * ie * ie.transpose() / (1 + var * iee);
    mean.row(0) /= eta_m;  // log eta_m -> eta_m
    mean.col(0) /= eta_m;
    out.information.topLeftCorner<4, 4>() += mean;
    const double e_sigma_e = iee / (1 + var * iee);
    out.information(4, 4) += 2 * var * e_sigma_e * e_sigma_e;
  }
  out.information = 0.5 * (out.information + out.information.transpose()).eval();
  return out;
}

}  // namespace rbc
