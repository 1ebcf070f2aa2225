// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/dynamics.hpp"

#include <Eigen/QR>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "continuum/continuum_stretch.hpp"
#include "continuum/newton_solver.hpp"
#include "core/geometry.hpp"
#include "core/validation.hpp"

namespace rbc {

void ContinuumDynamicsOptions::validate() const {
  if (!(shear_viscosity_pN_s_per_um > 0) || !std::isfinite(shear_viscosity_pN_s_per_um))
    throw std::invalid_argument("membrane viscosity must be finite and > 0 pN s/um, got " +
                                std::to_string(shear_viscosity_pN_s_per_um));
  if (!(dilatational_ratio >= 0) || !std::isfinite(dilatational_ratio))
    throw std::invalid_argument("dilatational/shear viscosity ratio must be >= 0, got " +
                                std::to_string(dilatational_ratio));
  if (!(normal_drag_pN_s_per_um3 >= 0))
    throw std::invalid_argument("normal drag must be >= 0 pN s/um^3, got " +
                                std::to_string(normal_drag_pN_s_per_um3));
  if (!(tolerance_pN_per_s > 0) || !(constraint_tolerance > 0) || max_iterations < 1 ||
      !(max_step_um > 0))
    throw std::invalid_argument("continuum dynamics tolerances and counts must be positive");
  require_finite_in_range("dynamics round-off force tolerance", "pN", min_tolerance_pN, 0.0, 1.0,
                          Ends::closed_closed);
  require_integer_in_range("dynamics factorisation reuse", max_factor_reuse, 0, 1000);
  require_finite_in_range("dynamics reuse contraction", "", reuse_contraction, 0.0, 1.0,
                          Ends::open_open);
}

namespace {

ShiftedNewtonOptions step_newton_options(const ContinuumDynamicsOptions& o) {
  ShiftedNewtonOptions c;
  c.force_tolerance = 1.0;  // replaced per step by max(tolerance_pN_per_s dt, floor)
  c.constraint_tolerance = o.constraint_tolerance;
  c.max_iterations = o.max_iterations;
  c.block_size = 3;
  c.max_step = o.max_step_um;
  c.max_line_search = 40;
  c.penalty = 1e4;     // merit penalty (pN um), as the static solver
  c.shift_memory = 0;  // each fresh factorisation starts from the smallest shift (measured: a
                       // memory of 0.01 saves nothing at dt = 1 ms, 108 vs 107 factorisations)
  c.max_factor_reuse = o.reuse_factorisation ? o.max_factor_reuse : 0;
  c.reuse_contraction = o.reuse_contraction;
  c.reuse_across_calls = o.reuse_factorisation;
  return c;
}

}  // namespace

namespace {

/// Normal fluid drag, incremental form: zeta a_i/(2 dt) ((x_i - x_i^n) . n_i^n)^2 with the
/// vertex area a_i and unit normal n_i at x_n (pN um); gradient and diagonal Hessian blocks.
struct NormalDrag {
  Eigen::Matrix3Xd normal;  ///< 3 x N unit normals at x_n
  Eigen::VectorXd coef;     ///< zeta a_i / dt (pN/um)
};

NormalDrag make_normal_drag(const Positions& x, const Topology& topo, double zeta, double dt) {
  NormalDrag d;
  d.normal = Eigen::Matrix3Xd::Zero(3, x.cols());
  d.coef = Eigen::VectorXd::Zero(x.cols());
  for (int f = 0; f < topo.num_faces(); ++f) {
    const auto t = topo.faces.col(f);
    const Vec3 n = (x.col(t(1)) - x.col(t(0))).cross(x.col(t(2)) - x.col(t(0)));
    for (int k = 0; k < 3; ++k) {
      d.normal.col(t(k)) += n;
      d.coef(t(k)) += n.norm() / 6.0;  // a third of the face area
    }
  }
  for (Eigen::Index i = 0; i < x.cols(); ++i) d.normal.col(i).normalize();
  d.coef *= zeta / dt;
  return d;
}

double normal_drag_energy(const NormalDrag& d, const Positions& xn, const Positions& x,
                          Positions* grad) {
  double e = 0.0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    const double s = (x.col(i) - xn.col(i)).dot(d.normal.col(i));
    e += 0.5 * d.coef(i) * s * s;
    if (grad) grad->col(i) += d.coef(i) * s * d.normal.col(i);
  }
  return e;
}

/// Removes from dx (flat 3N) its Euclidean projection on the rigid modes at x (flat 3N) that
/// the step's objective does not see: the three translations and the rotation about the
/// pulling axis x always, the other two rotations too when no force is applied.
void remove_rigid_modes(const Eigen::VectorXd& x, bool all_rotations, Eigen::VectorXd& dx) {
  const Eigen::Index n = x.size() / 3;
  const Eigen::Map<const Positions> xp(x.data(), 3, n);
  const Vec3 c = xp.rowwise().mean();
  const int k = all_rotations ? 6 : 4;
  Eigen::MatrixXd u = Eigen::MatrixXd::Zero(3 * n, k);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 r = xp.col(i) - c;
    for (int a = 0; a < 3; ++a) u(3 * i + a, a) = 1.0;
    u.block<3, 1>(3 * i, 3) = Vec3::UnitX().cross(r);
    if (all_rotations) {
      u.block<3, 1>(3 * i, 4) = Vec3::UnitY().cross(r);
      u.block<3, 1>(3 * i, 5) = Vec3::UnitZ().cross(r);
    }
  }
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(u);
  const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(3 * n, k);
  dx -= q * (q.transpose() * dx);
}

}  // namespace

ContinuumDynamics::ContinuumDynamics(const ContinuumModel& model,
                                     const ContinuumDynamicsOptions& options)
    : model_(model),
      options_((options.validate(), options)),
      hessian_(model.topo),
      newton_(step_newton_options(options)) {}

TrajectorySample ContinuumDynamics::measure(double force_pN, const DynamicsState& s) const {
  TrajectorySample t;
  t.energy_pNum = continuum_energy(model_, s.x, force_pN);
  const Diameters d = measure_diameters(s.x);
  t.axial_um = d.axial_um;
  t.transverse_um = d.transverse_um;
  t.area_drift = (total_area(s.x, model_.topo) - model_.area0_um2) / model_.area0_um2;
  t.volume_drift = (enclosed_volume(s.x, model_.topo) - model_.volume0_um3) / model_.volume0_um3;
  return t;
}

StepOutcome ContinuumDynamics::step(double force_pN, double dt, DynamicsState& state) {
  validate_continuum_force(force_pN);
  StepOutcome out;
  MembraneViscosity visc;
  visc.shear_pN_s_per_um = options_.shear_viscosity_pN_s_per_um;
  visc.dilatational_pN_s_per_um = options_.dilatational_ratio * visc.shear_pN_s_per_um;
  visc.dt_s = dt;
  visc.validate();
  const Positions xn = state.x;
  const std::vector<MembraneReference> prev = viscous_references(xn, model_.topo);
  const bool drag = options_.normal_drag_pN_s_per_um3 > 0;
  const NormalDrag nd =
      drag ? make_normal_drag(xn, model_.topo, options_.normal_drag_pN_s_per_um3, dt)
           : NormalDrag{};
  const int n = static_cast<int>(xn.cols());
  // The viscous Hessian scales with 1/dt and the tweezers' load with F: a factorisation kept
  // from a step of another length or force is no chord for this one.
  if (dt != factor_dt_s_ || force_pN != factor_force_pN_) newton_.forget_factorisation();
  factor_dt_s_ = dt;
  factor_force_pN_ = force_pN;

  ContinuumExtraTerms extra;
  extra.energy = [&](const Positions& x, Positions& grad) {
    double e = membrane_viscosity_energy(visc, model_.topo, prev, x, &grad);
    if (drag) e += normal_drag_energy(nd, xn, x, &grad);
    return e;
  };
  extra.hessian = [&](const Positions& x, BlockHessian& h) {
    add_membrane_viscosity_hessian(visc, model_.topo, prev, x, h);
  };
  NewtonProblem pb = continuum_newton_problem(model_, force_pN, hessian_, extra);
  if (drag)  // the drag's Hessian: coef_i n_i n_i^T in the diagonal block of vertex i
    pb.add_unshifted = [&](Eigen::SparseMatrix<double>& k) {
      for (int i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a)
          for (Eigen::SparseMatrix<double>::InnerIterator it(k, 3 * i + a); it; ++it)
            if (it.row() / 3 == i)
              it.valueRef() += nd.coef(i) * nd.normal(it.row() % 3, i) * nd.normal(a, i);
    };
  // Without the fluids' normal drag E + D do not see the rigid modes (D depends on the
  // metric only; the tweezers' load on the beads' x distance): project them out of each step
  // (a chord step's older factorisation would otherwise turn the residual's tiny component
  // along them, divided by the 1e-8 shift, into a spurious rotation).
  if (!drag)
    pb.project_step = [&](const Eigen::VectorXd& at, Eigen::VectorXd& dx) {
      remove_rigid_modes(at, force_pN == 0.0, dx);
    };
  NewtonLimitsCore lim;
  lim.force_tolerance = std::max(options_.tolerance_pN_per_s * dt, options_.min_tolerance_pN);
  const Eigen::VectorXd l0 =
      Eigen::Vector2d(state.lambda.area_pN_per_um, state.lambda.volume_pN_per_um2);
  Eigen::VectorXd xf, l = l0;
  ShiftedNewtonResult r;
  const bool continues =
      options_.extrapolate_start && last_dt_s_ > 0 && last_x_.cols() == n && last_x_ == xn;
  if (continues) {  // predictor: O(dt^2) from the step's solution
    xf = flat(xn) + (dt / last_dt_s_) * flat(last_step_);
    r = newton_.solve(pb, xf, l, {}, lim);
  }
  if (!continues || r.status == NewtonStatus::infeasible_start) {
    xf = flat(xn);
    l = l0;
    r = newton_.solve(pb, xf, l, {}, lim);
  }
  ++counters_.steps;
  counters_.iterations += r.iterations;
  counters_.factorisations += r.factorisations;
  counters_.chord_steps += r.chord_steps;
  out.iterations = r.iterations;
  out.residual_pN = r.residual;
  out.status = to_string(r.status);
  if (r.status == NewtonStatus::converged) {
    flat(state.x) = xf;
    state.lambda = {l(0), l(1)};
    out.converged = true;
    last_step_ = state.x - xn;
    last_x_ = state.x;
    last_dt_s_ = dt;
  } else {
    newton_.forget_factorisation();
    last_dt_s_ = 0.0;
  }
  return out;
}

}  // namespace rbc
