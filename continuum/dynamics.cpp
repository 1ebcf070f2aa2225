#include "continuum/dynamics.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "continuum/newton_solver.hpp"
#include "core/geometry.hpp"

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
}

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

}  // namespace

ContinuumDynamics::ContinuumDynamics(const ContinuumModel& model,
                                     const ContinuumDynamicsOptions& options)
    : model_(model), options_(options), hessian_(model.topo) {
  options_.validate();
  llt_.cholmod().print = 0;
  llt_.analyzePattern(hessian_.matrix());
}

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
  const double tol = options_.tolerance_pN_per_s * dt;
  const double a0 = model_.area0_um2, v0 = model_.volume0_um3;
  const int n = static_cast<int>(xn.cols());

  struct Iterate {
    double energy = 0;
    Positions grad;
    ConstraintValues cons;
  };
  auto evaluate = [&](const Positions& x, Iterate& it) {
    it.energy = continuum_energy(model_, x, force_pN, &it.grad);
    if (!std::isfinite(it.energy)) return false;
    it.energy += membrane_viscosity_energy(visc, model_.topo, prev, x, &it.grad);
    if (drag) it.energy += normal_drag_energy(nd, xn, x, &it.grad);
    it.cons = evaluate_constraints(x, model_.topo);
    return true;
  };
  Positions x = xn;
  ConstraintMultipliers lambda = state.lambda;
  Iterate cur, trial;
  if (!evaluate(x, cur)) {
    out.status = "infeasible start";
    return out;
  }
  Eigen::SparseMatrix<double> k = hessian_.matrix();
  std::vector<int> diag(3 * n);
  for (int c = 0; c < 3 * n; ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(k, c); it; ++it)
      if (it.row() == c) diag[c] = static_cast<int>(&it.valueRef() - k.valuePtr());
  const Eigen::Vector2d scale(a0, v0);
  const double rho = 1e4;  // merit penalty (pN um), as the static solver
  for (int iter = 0;; ++iter) {
    const Positions r = cur.grad + lambda.area_pN_per_um * cur.cons.grad_area +
                        lambda.volume_pN_per_um2 * cur.cons.grad_volume;
    const double resid = largest_vertex_norm(r);
    const Eigen::Vector2d c(cur.cons.area_um2 - a0, cur.cons.volume_um3 - v0);
    const Eigen::Vector2d chat = c.cwiseQuotient(scale);
    out.iterations = iter;
    out.residual_pN = resid;
    if (resid < tol && chat.cwiseAbs().maxCoeff() < options_.constraint_tolerance) {
      state.x = x;
      state.lambda = lambda;
      out.converged = true;
      out.status = "converged";
      return out;
    }
    if (iter >= options_.max_iterations) {
      out.status = "iteration limit reached";
      return out;
    }
    hessian_.set_zero();
    add_continuum_hessian(model_, x, hessian_);
    add_membrane_viscosity_hessian(visc, model_.topo, prev, x, hessian_);
    add_constraint_hessian(x, model_.topo, lambda.area_pN_per_um, lambda.volume_pN_per_um2,
                           hessian_);
    const Eigen::SparseMatrix<double>& h = hessian_.matrix();
    double mean_diag = 0;
    for (int d : diag) mean_diag += std::abs(h.valuePtr()[d]);
    mean_diag = std::max(mean_diag / (3.0 * n), 1e-300);
    double sigma = 1e-8;
    bool factorised = false;
    for (int attempt = 0; attempt < 30 && !factorised; ++attempt) {
      std::copy(h.valuePtr(), h.valuePtr() + h.nonZeros(), k.valuePtr());
      for (int d : diag) k.valuePtr()[d] += sigma * mean_diag;
      if (drag)  // the drag's Hessian: coef_i n_i n_i^T in the diagonal block of vertex i
        for (int i = 0; i < n; ++i)
          for (int a = 0; a < 3; ++a)
            for (Eigen::SparseMatrix<double>::InnerIterator it(k, 3 * i + a); it; ++it)
              if (it.row() / 3 == i)
                it.valueRef() += nd.coef(i) * nd.normal(it.row() % 3, i) * nd.normal(a, i);
      llt_.factorize(k);
      factorised = llt_.info() == Eigen::Success;
      if (!factorised) sigma = std::max(10.0 * sigma, 1e-4);
    }
    if (!factorised) {
      out.status = "factorisation failed";
      return out;
    }
    Eigen::MatrixXd cm(3 * n, 2);
    cm.col(0) = flat(cur.cons.grad_area);
    cm.col(1) = flat(cur.cons.grad_volume);
    const Eigen::VectorXd y0 = llt_.solve(flat(r));
    const Eigen::MatrixXd ym = llt_.solve(cm);
    const Eigen::Matrix2d s = cm.transpose() * ym;
    const Eigen::Vector2d dl = s.fullPivLu().solve(c - cm.transpose() * y0);
    Eigen::VectorXd dx = -y0 - ym * dl;
    const ConstraintMultipliers lnew{lambda.area_pN_per_um + dl(0),
                                     lambda.volume_pN_per_um2 + dl(1)};
    const double largest = largest_vertex_norm(Eigen::Map<const Eigen::Matrix3Xd>(dx.data(), 3, n));
    if (largest > options_.max_step_um) dx *= options_.max_step_um / largest;
    const Positions dxp = Eigen::Map<const Eigen::Matrix3Xd>(dx.data(), 3, n);
    auto merit = [&](const Iterate& it) {
      const Eigen::Vector2d ci(it.cons.area_um2 - a0, it.cons.volume_um3 - v0);
      return it.energy + lnew.area_pN_per_um * ci(0) + lnew.volume_pN_per_um2 * ci(1) +
             0.5 * rho * ci.cwiseQuotient(scale).squaredNorm();
    };
    const Eigen::VectorXd gm = flat(cur.grad) +
                               cm * Eigen::Vector2d(lnew.area_pN_per_um, lnew.volume_pN_per_um2) +
                               cm * Eigen::Vector2d(rho * chat(0) / a0, rho * chat(1) / v0);
    const double slope = gm.dot(dx);
    const double phi0 = merit(cur);
    double t = 1.0;
    bool accepted = false;
    Positions xt;
    for (int ls = 0; ls < 40; ++ls, t *= 0.5) {
      xt = x + t * dxp;
      if (!evaluate(xt, trial)) continue;
      const double phi = merit(trial);
      const bool armijo = slope < 0 && phi <= phi0 + 1e-4 * t * slope;
      bool roundoff_ok = false;
      if (!armijo && phi <= phi0 + 1e-12 * std::abs(phi0)) {
        const Positions rt = trial.grad + lnew.area_pN_per_um * trial.cons.grad_area +
                             lnew.volume_pN_per_um2 * trial.cons.grad_volume;
        roundoff_ok = largest_vertex_norm(rt) < resid;
      }
      if (armijo || roundoff_ok) {
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      out.status = "line search failed";
      return out;
    }
    x = xt;
    std::swap(cur, trial);
    lambda = lnew;
  }
}

}  // namespace rbc
