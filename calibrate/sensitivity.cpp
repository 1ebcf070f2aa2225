// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/sensitivity.hpp"

#include <omp.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "calibrate/smooth_patch.hpp"
#include "continuum/block_hessian.hpp"
#include "continuum/continuum_model.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/reduced_hessian.hpp"
#include "core/geometry.hpp"
#include "core/io.hpp"
#include "core/mirror_symmetry.hpp"
#include "core/sparse_cholesky.hpp"
#include "core/units.hpp"
#include "core/validation.hpp"
#include "discrete/network.hpp"
#include "discrete/network_hessian.hpp"
#include "homogenise/invariant_laws.hpp"

namespace rbc {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Largest distance (um) of an equilibrium from its symmetric part for the reduced solve: the
/// symmetric solves' equilibria are symmetric to round-off (core/mirror_symmetry.hpp), a
/// buckled one is off by far more.
constexpr double kSymmetricStateUm = 1e-8;

double& parameter_ref(ForwardParameters& p, Parameter q) {
  switch (q) {
    case Parameter::persistence:
      return p.persistence_nm;
    case Parameter::lmax:
      return p.lmax_nm;
    case Parameter::kappa:
      return p.kappa_J;
    case Parameter::contact_fraction:
      return p.contact_fraction;
    case Parameter::sigma_scale:
    case Parameter::eta_m:
    case Parameter::tau:
    case Parameter::eta_spread:
      break;
  }
  throw std::invalid_argument("sensitivities: '" + to_string(q) +
                              "' does not enter the forward model");
}

/// The vertex pair whose (y, z) distance is the largest (D_T of measure_diameters): over the
/// pairs of convex-hull vertices (Andrew's monotone chain, as core/geometry.cpp).
std::pair<int, int> transverse_pair(const Positions& x) {
  const int n = static_cast<int>(x.cols());
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return x(1, a) < x(1, b) || (x(1, a) == x(1, b) && x(2, a) < x(2, b));
  });
  const auto cross = [&](int o, int a, int b) {
    return (x(1, a) - x(1, o)) * (x(2, b) - x(2, o)) - (x(2, a) - x(2, o)) * (x(1, b) - x(1, o));
  };
  std::vector<int> hull(2 * static_cast<size_t>(n) + 1);
  size_t k = 0;
  for (int i = 0; i < n; ++i) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], order[i]) <= 0) --k;
    hull[k++] = order[i];
  }
  for (int i = n - 1, t = static_cast<int>(k) + 1; i-- > 0;) {
    while (static_cast<int>(k) >= t && cross(hull[k - 2], hull[k - 1], order[i]) <= 0) --k;
    hull[k++] = order[i];
  }
  hull.resize(k > 1 ? k - 1 : k);
  std::pair<int, int> best{order.front(), order.front()};
  double best_d2 = -1;
  for (size_t a = 0; a < hull.size(); ++a)
    for (size_t b = a + 1; b < hull.size(); ++b) {
      const double dy = x(1, hull[a]) - x(1, hull[b]), dz = x(2, hull[a]) - x(2, hull[b]);
      const double d2 = dy * dy + dz * dz;
      if (d2 > best_d2) {
        best_d2 = d2;
        best = {hull[a], hull[b]};
      }
    }
  return best;
}

Eigen::VectorXd energy_gradient(const ContinuumModel& m, const Positions& x, double force_pN) {
  Positions g(3, x.cols());
  const double e = continuum_energy(m, x, force_pN, &g);
  if (!std::isfinite(e))
    throw std::runtime_error("sensitivities: the energy is not finite at the equilibrium");
  return Eigen::Map<const Eigen::VectorXd>(g.data(), g.size());
}

/// The network's energy gradient without its area/volume term (pN): the terms that depend on
/// the parameters, and the tweezers. The constraints enter through exact multipliers instead.
Eigen::VectorXd energy_gradient(const Network& net, const Positions& x, double force_pN) {
  std::vector<NetworkTerm> terms;
  for (const NetworkTerm& t : model_terms(net))
    if (t.kind != TermKind::area_volume) terms.push_back(t);
  LoadState load;
  load.force_pN = force_pN;
  Positions g(3, x.cols());
  EnergyBreakdown parts;
  const double e = sum_network_terms(terms, net, x, load, &g, &parts);
  if (!std::isfinite(e))
    throw std::runtime_error("sensitivities: the energy is not finite at the equilibrium");
  return Eigen::Map<const Eigen::VectorXd>(g.data(), g.size());
}

/// Orthonormal basis (columns) of the rigid modes of x: 3 translations and the rotation about
/// the x axis through the centroid.
Eigen::MatrixXd rigid_modes(const Positions& x) {
  const Eigen::Index n = x.cols();
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(3 * n, 4);
  const Eigen::Vector3d c = x.rowwise().mean();
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) r(3 * i + a, a) = 1;
    r(3 * i + 1, 3) = -(x(2, i) - c(2));
    r(3 * i + 2, 3) = x(1, i) - c(1);
  }
  for (int j = 0; j < 4; ++j) {  // Gram-Schmidt (twice for round-off)
    for (int pass = 0; pass < 2; ++pass)
      for (int i = 0; i < j; ++i) r.col(j) -= r.col(i).dot(r.col(j)) * r.col(i);
    r.col(j).normalize();
  }
  return r;
}
}  // namespace

void SensitivityOptions::validate() const {
  require_finite_in_range("sensitivity relative step", "", relative_step, 0.0, 0.1,
                          Ends::open_open);
  require_finite_in_range("sensitivity CG tolerance", "", cg_tolerance, 0.0, 1.0, Ends::open_open);
  require_integer_in_range("sensitivity CG iterations", max_cg_iterations, 1, 1000000);
}

bool StretchSensitivities::converged() const {
  for (const auto& f : forces)
    if (!f.cg_converged) return false;
  return true;
}

bool is_forward_parameter(Parameter p) {
  return p == Parameter::persistence || p == Parameter::lmax || p == Parameter::kappa ||
         p == Parameter::contact_fraction;
}

struct StretchSensitivity::Impl {
  ForwardOptions options;
  SensitivityOptions sens;
  bool discrete = false;
  ContinuumModel model;        ///< continuum forward model
  Network network;             ///< discrete forward model
  MeshSymmetry mesh_symmetry;  ///< the rest mesh's mirrors (options.newton.symmetry = mirror)
};

StretchSensitivity::StretchSensitivity(const ForwardOptions& options, const SensitivityOptions& s)
    : impl_(std::make_unique<Impl>()) {
  options.validate();
  s.validate();
  impl_->options = options;
  impl_->discrete = options.method.kind == MethodKind::discrete;
  impl_->sens = s;
  // The forward model's rest mesh, built on one thread as there (calibrate/forward_model.cpp).
  const int saved_threads = omp_get_max_threads();
  omp_set_num_threads(1);
  struct Restore {
    int n;
    ~Restore() { omp_set_num_threads(n); }
  } restore{saved_threads};
  if (impl_->discrete) {
    // The forward model's network; its solves run in full (StretchOptions' default symmetry).
    impl_->network = make_discrete_network(options.method.resolution);
    const NetworkParameters p;
    if (p.bending_model != BendingModel::juelicher)
      throw std::invalid_argument("sensitivities need Juelicher bending for the network");
    return;
  }
  const TriMesh mesh = make_continuum_mesh(options.method.resolution);
  if (options.newton.symmetry == Symmetry::mirror)
    impl_->mesh_symmetry = find_mirror_symmetry(mesh.x, mesh.topo);
  const NetworkParameters defaults;
  impl_->model = build_continuum_model(
      mesh, make_membrane_law(defaults.wlc, defaults.steric, options.method.order),
      ContinuumParameters{});
}

StretchSensitivity::~StretchSensitivity() = default;

int StretchSensitivity::vertices() const {
  return impl_->discrete ? impl_->network.topo.num_vertices : impl_->model.topo.num_vertices;
}

StretchSensitivities StretchSensitivity::compute(const ForwardParameters& parameters,
                                                 const std::vector<double>& forces_pN,
                                                 const WarmState& state,
                                                 const std::vector<Parameter>& wrt) const {
  parameters.validate();
  const SensitivityOptions& so = impl_->sens;
  const bool discrete = impl_->discrete;
  const int n = vertices();
  const Topology& topo = discrete ? impl_->network.topo : impl_->model.topo;
  const int per_force = 3 * n + 2;
  const int nf = static_cast<int>(forces_pN.size());
  if (static_cast<long long>(state.size()) != static_cast<long long>(nf) * per_force)
    throw std::invalid_argument("sensitivities: a state of " + std::to_string(state.size()) +
                                " values does not fit " + std::to_string(nf) + " forces of " +
                                std::to_string(n) + " vertices");
  StretchSensitivities out;
  out.parameters = wrt;
  const int np = static_cast<int>(wrt.size());
  // The models at theta and at theta +- h e_k (only the parameters change; mesh shared).
  const WlcExpansion order = impl_->options.method.order;
  ContinuumModel centre;
  Network centre_net;
  std::vector<ContinuumModel> plus, minus;
  std::vector<Network> plus_net, minus_net;
  if (discrete) {
    centre_net = impl_->network;
    apply_forward_parameters(centre_net, parameters);
  } else {
    centre = impl_->model;
    apply_forward_parameters(centre, parameters, order);
  }
  std::vector<double> step(np);
  for (int k = 0; k < np; ++k) {
    ForwardParameters pp = parameters, pm = parameters;
    const double v = parameter_ref(pp, wrt[k]);
    step[k] = so.relative_step * std::abs(v);
    parameter_ref(pp, wrt[k]) = v + step[k];
    parameter_ref(pm, wrt[k]) = v - step[k];
    if (discrete) {
      plus_net.push_back(impl_->network);
      minus_net.push_back(impl_->network);
      apply_forward_parameters(plus_net.back(), pp);
      apply_forward_parameters(minus_net.back(), pm);
    } else {
      plus.push_back(impl_->model);
      minus.push_back(impl_->model);
      apply_forward_parameters(plus.back(), pp, order);
      apply_forward_parameters(minus.back(), pm, order);
    }
  }
  // grad_x E at x of the centre (k = -1) or of theta +- h e_k (pN).
  const auto gradient = [&](int k, bool up, const Positions& x, double force) {
    if (discrete)
      return energy_gradient(k < 0 ? centre_net : (up ? plus_net : minus_net)[k], x, force);
    return energy_gradient(k < 0 ? centre : (up ? plus : minus)[k], x, force);
  };
  // The mirror reduction the forward model solves on (continuum/newton_solver.cpp): the
  // mirrors of the mesh that keep the bead load, from the centre model's patch.
  const bool mirror = !discrete && impl_->options.newton.symmetry == Symmetry::mirror;
  std::unique_ptr<SymmetryReduction> red;
  std::unique_ptr<ReducedLagrangianHessian> reduced_hessian;
  if (mirror) {
    const MeshSymmetry g = keep_invariant(impl_->mesh_symmetry, centre.patch.vertex,
                                          centre.patch.share, 0, kTweezersShareTolerance);
    if (g.order() > 1) {
      red = std::make_unique<SymmetryReduction>(make_symmetry_reduction(g));
      reduced_hessian = std::make_unique<ReducedLagrangianHessian>(centre, g, *red);
    }
  }
  std::unique_ptr<BlockHessian> h;  // the full Hessian, made at its first use
  std::unique_ptr<NetworkHessian> h_net;
  SparseCholeskyOptions co;
  co.ordering = impl_->options.newton.ordering;
  SparseCholesky chol_full(co), chol_reduced(co);
  for (int f = 0; f < nf; ++f) {
    const double force = forces_pN[f];
    const double* w = state.data() + static_cast<size_t>(f) * per_force;
    const Positions x = Eigen::Map<const Positions>(w, 3, n);
    double la = w[3 * n], lv = w[3 * n + 1];
    ForceSensitivity fs;
    fs.force_pN = force;
    // Constraint gradients and the residual grad_x L.
    const ConstraintValues cv = evaluate_constraints(x, topo);
    Eigen::MatrixXd c(3 * n, 2);
    c.col(0) = Eigen::Map<const Eigen::VectorXd>(cv.grad_area.data(), 3 * n);
    c.col(1) = Eigen::Map<const Eigen::VectorXd>(cv.grad_volume.data(), 3 * n);
    auto t0 = Clock::now();
    const Eigen::VectorXd g0 = gradient(-1, true, x, force);
    if (discrete) {
      // The augmented-Lagrangian state holds multipliers and a penalty whose sum is the
      // tension and pressure: the exact multipliers are those that best balance grad E,
      // min |grad E + C lambda| (equal to the constrained problem's at an equilibrium).
      const Eigen::Vector2d l = (c.transpose() * c).ldlt().solve(-c.transpose() * g0);
      la = l(0);
      lv = l(1);
    }
    const Eigen::VectorXd r0 = g0 + la * c.col(0) + lv * c.col(1);
    double res = 0;
    for (int i = 0; i < n; ++i) res = std::max(res, r0.segment<3>(3 * i).norm());
    fs.residual_pN = res;
    // Mixed derivatives d(grad_x E)/dtheta_k (the constraint terms do not depend on theta).
    Eigen::MatrixXd b(3 * n, np);
    for (int k = 0; k < np; ++k)
      b.col(k) = (gradient(k, true, x, force) - gradient(k, false, x, force)) / (2 * step[k]);
    out.mixed_s += seconds_since(t0);
    // On a symmetric equilibrium the system is solved on the symmetric subspace u = P q
    // (P'HP q + P'C dlambda = -P'b, C'P q = 0: the full system's solution, which is
    // symmetric there); otherwise (a buckled cell) in full.
    bool reduced = false;
    if (red) {
      const Eigen::VectorXd xs = flat(x);
      reduced =
          (expand(*red, symmetric_part(*red, xs)) - xs).cwiseAbs().maxCoeff() <= kSymmetricStateUm;
    }
    fs.reduced = reduced;
    const Eigen::MatrixXd rigid_full = rigid_modes(x);
    Eigen::MatrixXd cs = c, bs = b, rigid;
    if (reduced) {
      cs = reduce(*red, c);
      bs = reduce(*red, b);
      // The rigid modes that are symmetric (each lies in one sector of the group).
      std::vector<Eigen::VectorXd> kept;
      for (int j = 0; j < 4; ++j) {
        Eigen::VectorXd q = symmetric_part(*red, Eigen::VectorXd(rigid_full.col(j)));
        if (expand(*red, q).norm() < 0.5) continue;  // antisymmetric (unit vector: 0 or 1)
        for (int pass = 0; pass < 2; ++pass)
          for (const auto& v : kept) q -= v.dot(q) * v;
        kept.push_back(q.normalized());
      }
      rigid.resize(red->reduced_size, static_cast<Eigen::Index>(kept.size()));
      for (size_t j = 0; j < kept.size(); ++j) rigid.col(static_cast<Eigen::Index>(j)) = kept[j];
    } else {
      rigid = rigid_full;
    }
    // The exact Hessian of the Lagrangian and the shifted factorisation.
    t0 = Clock::now();
    const Eigen::SparseMatrix<double>* hp = nullptr;
    if (reduced) {
      reduced_hessian->rebind(centre);
      hp = &reduced_hessian->assemble(x, la, lv);
    } else if (discrete) {
      // The exact Hessian of the network (unprojected, Juelicher's hinge curvature included)
      // plus the constraint curvature lambda_A d2A + lambda_V d2V.
      if (!h_net) {
        NetworkHessianOptions ho;
        ho.bending_coupling = BendingCoupling::two_ring;
        ho.shift_fraction = 0;
        ho.project = false;
        ho.hinge_curvature = true;
        h_net = std::make_unique<NetworkHessian>(centre_net, ho);
      }
      hp = &h_net->assemble_exact(x, ConstraintCurvature{la, lv});
    } else {
      if (!h) h = std::make_unique<BlockHessian>(centre.topo, BlockStorage::lower);
      h->set_zero();
      add_lagrangian_hessian(centre, x, la, lv, *h);
      hp = &h->matrix();
    }
    const Eigen::SparseMatrix<double>& hm = *hp;
    SparseCholesky& chol = reduced ? chol_reduced : chol_full;
    const Eigen::Index dim = hm.rows();
    out.hessian_s += seconds_since(t0);
    t0 = Clock::now();
    double scale = 0;
    for (Eigen::Index i = 0; i < dim; ++i) scale += std::abs(hm.coeff(i, i));
    scale /= static_cast<double>(dim);
    double sigma = 1e-8;
    bool ok = false;
    for (int attempt = 0; attempt < 12 && !ok; ++attempt, sigma *= 10)
      ok = chol.factorize(hm, sigma * scale);
    if (!ok)
      throw std::runtime_error("sensitivities: H + sigma I not positive definite up to sigma = " +
                               std::to_string(sigma) + " x mean diagonal at " +
                               std::to_string(force) + " pN");
    sigma /= 10;
    fs.shift = sigma;
    out.factorise_s += seconds_since(t0);
    t0 = Clock::now();
    const auto hmul = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
      return hm.selfadjointView<Eigen::Lower>() * v;
    };
    const bool bordered = !so.drop_multiplier_rows;
    const Eigen::MatrixXd y = chol.solve(cs);  // K^-1 C
    const Eigen::Matrix2d s = cs.transpose() * y;
    const Eigen::FullPivLU<Eigen::Matrix2d> slu(s);
    // The constraint preconditioner: z = K^-1 (r - C m), C'z = 0; m returned.
    // The rigid modes are projected out of z (they lie in the tangent space, so C'z = 0 stays):
    // H's null vectors, which round-off would otherwise feed into the search directions.
    const auto precondition = [&](const Eigen::VectorXd& r, Eigen::Vector2d& m) {
      Eigen::VectorXd z = chol.solve(r);
      if (bordered) {
        m = slu.solve(y.transpose() * r);
        z -= y * m;
      } else {
        m.setZero();
      }
      if (rigid.cols() > 0) z -= rigid * (rigid.transpose() * z);
      return z;
    };
    const auto [ia, ib] = transverse_pair(x);
    Eigen::Index imax = 0, imin = 0;
    x.row(0).maxCoeff(&imax);
    x.row(0).minCoeff(&imin);
    fs.axial_vertices[0] = static_cast<int>(imax);
    fs.axial_vertices[1] = static_cast<int>(imin);
    fs.transverse_vertices[0] = ia;
    fs.transverse_vertices[1] = ib;
    const Eigen::Vector2d pab(x(1, ia) - x(1, ib), x(2, ia) - x(2, ib));
    fs.axial_um = x(0, imax) - x(0, imin);
    fs.transverse_um = pab.norm();
    for (int k = 0; k < np; ++k) {
      // min 1/2 u'Hu + b'u subject to C'u = 0 by projected PCG.
      Eigen::VectorXd u = Eigen::VectorXd::Zero(dim);
      Eigen::VectorXd r = bs.col(k);
      Eigen::Vector2d m, mult = Eigen::Vector2d::Zero();
      Eigen::VectorXd z = precondition(r, m);
      r -= cs * m;
      mult += m;
      double rz = r.dot(z);
      const double rz0 = rz;
      Eigen::VectorXd d = -z;
      int it = 0;
      bool converged = !(rz0 > 0);
      while (!converged && it < so.max_cg_iterations) {
        const Eigen::VectorXd hd = hmul(d);
        const double dhd = d.dot(hd);
        if (!(dhd > 0)) {
          // No positive curvature along d: at the round-off floor (the residual already 1e-6
          // of its start) the solve is done; before it, H is not positive on the tangent
          // space (not a stable equilibrium) and the solve has failed.
          converged = rz <= 1e-12 * rz0;
          break;
        }
        const double alpha = rz / dhd;
        u += alpha * d;
        r += alpha * hd;
        z = precondition(r, m);
        r -= cs * m;
        mult += m;
        const double rz_new = r.dot(z);
        ++it;
        if (std::abs(rz_new) <= so.cg_tolerance * so.cg_tolerance * rz0) {
          converged = true;
          break;
        }
        d = -z + (rz_new / rz) * d;
        rz = rz_new;
      }
      fs.cg_iterations += it;
      fs.cg_converged = fs.cg_converged && converged;
      Eigen::VectorXd uf = reduced ? expand(*red, u) : u;
      uf -= rigid_full * (rigid_full.transpose() * uf);
      // H u + b = C mult at convergence: H u + C dlambda = -b with dlambda = -mult.
      fs.d_area_multiplier.push_back(-mult(0));
      fs.d_volume_multiplier.push_back(-mult(1));
      fs.d_axial.push_back(uf(3 * imax) - uf(3 * imin));
      const Eigen::Vector2d dab(uf(3 * ia + 1) - uf(3 * ib + 1), uf(3 * ia + 2) - uf(3 * ib + 2));
      fs.d_transverse.push_back(fs.transverse_um > 0 ? pab.dot(dab) / fs.transverse_um : 0.0);
    }
    out.solve_s += seconds_since(t0);
    out.forces.push_back(std::move(fs));
  }
  return out;
}

namespace {
/// The error of `what` with its context (the identifiability report's stages).
template <class F>
auto in_context(const std::string& what, F&& f) {
  try {
    return f();
  } catch (const std::exception& e) {
    throw std::runtime_error(what + ": " + e.what());
  }
}

/// Relative step of the recovery term's central differences in p, Lmax and kappa. The
/// trajectories carry solver noise (a step halved or not changes the curve by ~dt^2), which a
/// step of 1e-3 turns into errors of 1-4 % of d log L/dp on 200 elements
/// (tests/calibrate/test_joint_gradient.cpp); at 1e-2 the noise over h is 10 times smaller and
/// the truncation, O(h^2) relative, stays near 1e-4.
constexpr double kRecoveryRelativeStep = 1e-2;

LikelihoodGradient likelihood_gradient(const InferenceProblem& problem,
                                       const std::vector<const ForwardModel*>& forwards,
                                       const StretchSensitivity& sensitivity,
                                       std::span<const double> theta, const WarmState& warm) {
  const std::vector<ParameterSlot>& slots = problem.slots();
  const int d = static_cast<int>(slots.size());
  if (static_cast<int>(theta.size()) != d)
    throw std::invalid_argument("theta of " + std::to_string(theta.size()) + " values for " +
                                std::to_string(d) + " parameters");
  if (problem.has_recovery())
    for (const ParameterSlot& q : slots)
      if (q.parameter == Parameter::contact_fraction)
        throw std::invalid_argument(
            "the likelihood gradient of recovery data covers persistence, lmax, kappa and eta-m; "
            "this problem infers contact-fraction");
  LikelihoodGradient out;
  // The physical parameters differentiated (each once, in slot order of first appearance).
  std::vector<Parameter> physical;
  for (const ParameterSlot& q : slots)
    if (is_forward_parameter(q.parameter) &&
        std::find(physical.begin(), physical.end(), q.parameter) == physical.end())
      physical.push_back(q.parameter);
  // One forward run and its sensitivities per group.
  std::vector<ModelDiameters> diameters;
  std::vector<StretchSensitivities> sens;
  auto t0 = Clock::now();
  size_t offset = 0;
  bool converged = true;
  for (int g = 0; g < problem.groups(); ++g) {
    const size_t size = problem.group_state_size(g);
    WarmState slice;
    if (warm.size() == problem.state_size())
      slice.assign(warm.begin() + static_cast<std::ptrdiff_t>(offset),
                   warm.begin() + static_cast<std::ptrdiff_t>(offset + size));
    offset += size;
    const ForwardParameters p = problem.group_physical(theta, g);
    const ForwardRun run = in_context("forward run", [&] { return forwards[g]->run(p, slice); });
    if (!run.converged) {
      out.failed = true;
      out.log_likelihood = -std::numeric_limits<double>::infinity();
      out.forward_s = seconds_since(t0);
      return out;
    }
    const auto t1 = Clock::now();
    sens.push_back(in_context("sensitivities", [&] {
      return sensitivity.compute(p, forwards[g]->options().forces_pN, run.state, physical);
    }));
    out.sensitivity_s += seconds_since(t1);
    converged = converged && sens.back().converged();
    diameters.push_back(run.diameters);
    out.state.insert(out.state.end(), run.state.begin(), run.state.end());
  }
  out.forward_s = seconds_since(t0) - out.sensitivity_s;
  t0 = Clock::now();
  out.diameters = diameters.front();
  out.sensitivities = sens.front();
  const double scale = problem.sigma_scale(theta), tau = problem.tau(theta);
  out.log_likelihood = 0;
  out.gradient.assign(d, 0.0);
  out.information = Eigen::MatrixXd::Zero(d, d);
  int scale_slot = -1, tau_slot = -1;
  for (int k = 0; k < d; ++k) {
    if (slots[k].parameter == Parameter::sigma_scale) scale_slot = k;
    if (slots[k].parameter == Parameter::tau) tau_slot = k;
  }
  // Per experiment and column (D_A, D_T): residuals, error bars and their Jacobian in the slots
  // that move this experiment's model, then the Gaussian block (calibrate/likelihood.hpp).
  for (size_t ei = 0; ei < problem.experiments().size(); ++ei) {
    const Experiment& e = problem.experiments()[ei];
    if (e.kind == DataKind::recovery) continue;
    const DiameterData& data = e.data;
    const ModelDiameters& model = diameters[e.group];
    const StretchSensitivities& gs = sens[e.group];
    for (int column = 0; column < 2; ++column) {
      std::vector<double> r, sigma;
      std::vector<std::vector<double>> rows;
      for (int i = 0; i < data.size(); ++i) {
        const int f = e.force_index[i];
        if (column == 1 && !data.transverse_used[i]) continue;
        r.push_back(column == 0 ? model.axial_um[f] - data.axial_um[i]
                                : model.transverse_um[f] - data.transverse_um[i]);
        sigma.push_back(column == 0 ? data.axial_sigma_um[i] : data.transverse_sigma_um[i]);
        std::vector<double> row(d, 0.0);
        for (int k = 0; k < d; ++k) {
          if (!is_forward_parameter(slots[k].parameter)) continue;
          if (slots[k].experiment >= 0 && slots[k].experiment != static_cast<int>(ei)) continue;
          const size_t j = static_cast<size_t>(
              std::find(physical.begin(), physical.end(), slots[k].parameter) - physical.begin());
          const ForceSensitivity& fs = gs.forces[f];
          row[k] = column == 0 ? fs.d_axial[j] : fs.d_transverse[j];
        }
        rows.push_back(std::move(row));
      }
      const int n = static_cast<int>(r.size());
      std::vector<double> jac(static_cast<size_t>(n) * d);
      for (int i = 0; i < n; ++i)
        for (int k = 0; k < d; ++k) jac[static_cast<size_t>(k) * n + i] = rows[i][k];
      const GaussianBlockGradient b = gaussian_block_gradient(r, sigma, jac, d, scale, tau);
      out.log_likelihood += b.log_density;
      for (int k = 0; k < d; ++k) {
        out.gradient[k] += b.gradient[k];
        for (int l = 0; l < d; ++l) out.information(k, l) += b.information[l * d + k];
      }
      if (scale_slot >= 0) {
        out.gradient[scale_slot] += b.d_scale;
        out.information(scale_slot, scale_slot) += b.info_scale;
      }
      if (tau_slot >= 0) {
        out.gradient[tau_slot] += b.d_tau;
        out.information(tau_slot, tau_slot) += b.info_tau;
      }
      if (scale_slot >= 0 && tau_slot >= 0) {
        out.information(scale_slot, tau_slot) += b.info_scale_tau;
        out.information(tau_slot, scale_slot) += b.info_scale_tau;
      }
    }
  }
  // Recovery experiments (calibrate/recovery_likelihood.hpp): the release scene's term, its
  // gradient (eta_m analytic, p, Lmax, kappa by central differences of trajectories) and its
  // Gauss-Newton information with the cells' nuisances eliminated, in the slots that move it.
  for (size_t ei = 0; ei < problem.experiments().size(); ++ei) {
    const Experiment& e = problem.experiments()[ei];
    if (e.kind != DataKind::recovery) continue;
    // Slot k's index in (eta_m, persistence, lmax, kappa, eta-spread), -1 when it does not move
    // this term.
    std::vector<int> index(d, -1);
    std::array<bool, 3> differentiate{false, false, false};
    for (int k = 0; k < d; ++k) {
      if (slots[k].experiment >= 0 && slots[k].experiment != static_cast<int>(ei)) continue;
      switch (slots[k].parameter) {
        case Parameter::eta_m:
          index[k] = 0;
          break;
        case Parameter::persistence:
          index[k] = 1;
          break;
        case Parameter::lmax:
          index[k] = 2;
          break;
        case Parameter::kappa:
          index[k] = 3;
          break;
        case Parameter::eta_spread:
          index[k] = 4;
          break;
        default:
          break;
      }
      if (index[k] > 0 && index[k] < 4) differentiate[index[k] - 1] = true;
    }
    // Without eta-spread every cell at eta_m; with it, each at its own viscosity, integrated
    // out (calibrate/recovery_likelihood.hpp recovery_spread_gradient_and_information).
    const double spread = problem.eta_spread(theta);
    const RecoverySpreadGradientInformation ri = in_context("recovery gradient", [&] {
      const ForwardParameters at = problem.physical(theta, static_cast<int>(ei));
      if (spread != 0)
        return recovery_spread_gradient_and_information(
            *problem.recovery_model(), at, problem.eta_m(theta), spread, *e.recovery,
            problem.options().recovery_likelihood, differentiate, kRecoveryRelativeStep);
      const RecoveryGradientInformation shared = recovery_gradient_and_information(
          *problem.recovery_model(), at, problem.eta_m(theta), *e.recovery,
          problem.options().recovery_likelihood, differentiate, kRecoveryRelativeStep);
      RecoverySpreadGradientInformation r;
      r.gradient = shared.gradient;
      r.information.topLeftCorner<4, 4>() = shared.information;
      r.trajectories = shared.trajectories;
      return r;
    });
    out.recovery_trajectories += ri.trajectories;
    if (!ri.gradient.converged) {
      out.failed = true;
      out.log_likelihood = -std::numeric_limits<double>::infinity();
      out.sensitivity_s += seconds_since(t0);
      return out;
    }
    const RecoveryGradient& rg = ri.gradient;
    const double dlog[5] = {rg.d_eta_per_pN_s_per_um, rg.d_persistence_per_nm, rg.d_lmax_per_nm,
                            rg.d_kappa_per_J, rg.d_spread};
    out.log_likelihood += rg.log_likelihood;
    for (int k = 0; k < d; ++k) {
      if (index[k] < 0) continue;
      out.gradient[k] += dlog[index[k]];
      for (int l = 0; l < d; ++l)
        if (index[l] >= 0) out.information(k, l) += ri.information(index[k], index[l]);
    }
  }
  // A sensitivity solve that did not converge (an equilibrium that is not a strict minimum on
  // the constraints' tangent space): no gradient of the physical parameters.
  if (!converged)
    for (int k = 0; k < d; ++k)
      if (is_forward_parameter(slots[k].parameter))
        out.gradient[k] = std::numeric_limits<double>::quiet_NaN();
  out.sensitivity_s += seconds_since(t0);
  return out;
}
}  // namespace

LikelihoodGradient log_likelihood_and_gradient(const InferenceProblem& problem,
                                               const StretchSensitivity& sensitivity,
                                               std::span<const double> theta,
                                               const WarmState& warm) {
  std::vector<const ForwardModel*> forwards;
  for (int g = 0; g < problem.groups(); ++g) forwards.push_back(&problem.forward(g));
  return likelihood_gradient(problem, forwards, sensitivity, theta, warm);
}

// ---------------------------------------------------------------------------------------------
// Identifiability

namespace {
double interpolate(const std::vector<double>& xs, const std::vector<double>& ys, double x,
                   const std::vector<char>* used = nullptr) {
  std::vector<double> px, py;
  for (size_t i = 0; i < xs.size(); ++i)
    if (!used || (*used)[i]) {
      px.push_back(xs[i]);
      py.push_back(ys[i]);
    }
  if (px.empty()) return ys.empty() ? 0.0 : ys.front();
  if (x <= px.front()) return py.front();
  if (x >= px.back()) return py.back();
  const size_t j = static_cast<size_t>(std::upper_bound(px.begin(), px.end(), x) - px.begin());
  const double t = (x - px[j - 1]) / (px[j] - px[j - 1]);
  return py[j - 1] + t * (py[j] - py[j - 1]);
}

std::string percent(double sd_log) {
  std::ostringstream s;
  if (sd_log > 1)
    s << "not determined (1-sigma " << std::setprecision(2) << sd_log << " in log, > 100 %)";
  else
    s << "to " << std::setprecision(2) << 100 * sd_log << " %";
  return s.str();
}

std::string combination_text(const std::vector<double>& c, const std::vector<std::string>& names) {
  std::ostringstream s;
  bool first = true;
  for (size_t k = 0; k < c.size(); ++k) {
    if (std::abs(c[k]) < 0.05) continue;
    s << (first ? (c[k] < 0 ? "-" : "") : (c[k] < 0 ? " - " : " + ")) << std::fixed
      << std::setprecision(2) << std::abs(c[k]) << " log " << names[k];
    first = false;
  }
  return s.str();
}
}  // namespace

IdentifiabilityReport identifiability(const InferenceProblem& problem,
                                      std::span<const double> theta,
                                      const std::vector<double>& candidate_forces_pN) {
  const auto t0 = Clock::now();
  IdentifiabilityReport rep;
  std::vector<Parameter> params;  // per slot of theta
  for (const ParameterSlot& q : problem.slots()) params.push_back(q.parameter);
  const int d = static_cast<int>(params.size());
  rep.names = problem.names();
  rep.at.assign(theta.begin(), theta.end());
  for (double f : candidate_forces_pN)
    validate_method_force(problem.forward().options().method.kind, f);
  // Forward models of its own (the problem's meshes and options): the result does not depend
  // on what the problem's pooled workspaces solved before.
  const StretchSensitivity sens(problem.forward().options());
  std::vector<std::unique_ptr<ForwardModel>> own;
  std::vector<const ForwardModel*> forwards;
  for (int g = 0; g < problem.groups(); ++g) {
    own.push_back(std::make_unique<ForwardModel>(problem.forward(g).options()));
    forwards.push_back(own.back().get());
  }
  const LikelihoodGradient lg = in_context(
      "at the point", [&] { return likelihood_gradient(problem, forwards, sens, theta, {}); });
  if (lg.failed) {
    rep.status = "forward run failed at the point";
    return rep;
  }
  for (double g : lg.gradient)
    if (std::isnan(g)) {
      rep.status = "sensitivity solve did not converge at the point";
      return rep;
    }
  // The first experiment's error bars for the candidate forces (one more point in it).
  const DiameterData& data = problem.data();
  const double scale = problem.sigma_scale(theta);
  // Index in theta of each physical parameter of the first experiment, in sensitivity order.
  std::vector<int> phys;
  for (int k = 0; k < d; ++k)
    if (is_forward_parameter(params[k]) && problem.slots()[k].experiment <= 0) phys.push_back(k);
  // Gauss-Newton information in log parameters: diag(theta) F diag(theta), F that of the
  // whitened residuals of every experiment (likelihood_gradient).
  Eigen::MatrixXd fisher = lg.information;
  for (int k = 0; k < d; ++k)
    for (int l = 0; l < d; ++l) fisher(k, l) *= theta[k] * theta[l];
  rep.fisher_log = fisher;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(fisher);
  for (int e = d - 1; e >= 0; --e) {
    IdentifiedCombination c;
    Eigen::VectorXd v = eig.eigenvectors().col(e);
    Eigen::Index big = 0;
    v.cwiseAbs().maxCoeff(&big);
    if (v(big) < 0) v = -v;
    c.coefficients.assign(v.data(), v.data() + d);
    c.eigenvalue = std::max(0.0, eig.eigenvalues()(e));
    c.sd_log =
        c.eigenvalue > 0 ? 1 / std::sqrt(c.eigenvalue) : std::numeric_limits<double>::infinity();
    c.text = combination_text(c.coefficients, rep.names);
    rep.combinations.push_back(std::move(c));
  }
  // Prior box information in log parameters (uniform of width w in log: variance w^2/12).
  const PriorBox& box = problem.prior();
  Eigen::MatrixXd posterior = fisher;
  for (int k = 0; k < d; ++k) {
    if (box.lower[k] > 0 && box.upper[k] > box.lower[k]) {
      const double wlog = std::log(box.upper[k] / box.lower[k]);
      posterior(k, k) += 12 / (wlog * wlog);
    }
  }
  // Derived moduli: gradients of log mu, log K in log p, log Lmax (central differences of
  // the closed forms).
  const ForwardParameters p0 = problem.physical(theta);
  const LinearModuli m0 = sample_moduli(p0);
  rep.mu_uN_per_m = m0.mu_pN_per_um * units::uN_per_m_per_pN_per_um;
  rep.k_uN_per_m = m0.K_pN_per_um * units::uN_per_m_per_pN_per_um;
  Eigen::VectorXd gmu = Eigen::VectorXd::Zero(d), gk = Eigen::VectorXd::Zero(d);
  bool moduli = false;
  for (int k = 0; k < d; ++k) {
    if (params[k] != Parameter::persistence && params[k] != Parameter::lmax) continue;
    if (problem.slots()[k].experiment > 0) continue;  // the first experiment's moduli
    moduli = true;
    ForwardParameters pp = p0, pm = p0;
    const double h = 1e-5;
    parameter_ref(pp, params[k]) *= std::exp(h);
    parameter_ref(pm, params[k]) *= std::exp(-h);
    const LinearModuli a = sample_moduli(pp), b = sample_moduli(pm);
    gmu(k) = (std::log(a.mu_pN_per_um) - std::log(b.mu_pN_per_um)) / (2 * h);
    gk(k) = (std::log(a.K_pN_per_um) - std::log(b.K_pN_per_um)) / (2 * h);
  }
  const Eigen::MatrixXd cov = posterior.inverse();
  if (moduli) {
    rep.mu_relative_sd = std::sqrt(std::max(0.0, gmu.dot(cov * gmu)));
    rep.k_relative_sd = std::sqrt(std::max(0.0, gk.dot(cov * gk)));
    const Eigen::Map<const Eigen::VectorXd> best(rep.combinations.front().coefficients.data(), d);
    rep.mu_alignment = gmu.norm() > 0 ? std::abs(best.dot(gmu)) / gmu.norm() : 0.0;
  }
  // Candidate forces: expected information gain over the physical parameters.
  if (!candidate_forces_pN.empty() && !phys.empty()) {
    std::vector<double> forces = candidate_forces_pN;
    std::sort(forces.begin(), forces.end());
    forces.erase(std::unique(forces.begin(), forces.end()), forces.end());
    ForwardOptions fo = problem.forward().options();
    fo.forces_pN = forces;
    const ForwardModel model(fo);
    const ForwardRun run =
        in_context("forward run at the candidate forces", [&] { return model.run(p0); });
    if (!run.converged) {
      rep.status = "forward run at the candidate forces failed";
    } else {
      std::vector<Parameter> physical;
      for (int k : phys) physical.push_back(params[k]);
      const StretchSensitivities cs = in_context("sensitivities at the candidate forces", [&] {
        return sens.compute(p0, forces, run.state, physical);
      });
      const int q = static_cast<int>(phys.size());
      Eigen::MatrixXd fpost(q, q);
      for (int a = 0; a < q; ++a)
        for (int b = 0; b < q; ++b) fpost(a, b) = posterior(phys[a], phys[b]);
      const Eigen::MatrixXd fpost_inv = fpost.inverse();
      for (size_t i = 0; i < forces.size(); ++i) {
        CandidateGain g;
        g.force_pN = forces[i];
        g.sigma_axial_um = interpolate(data.force_pN, data.axial_sigma_um, forces[i]);
        g.sigma_transverse_um =
            interpolate(data.force_pN, data.transverse_sigma_um, forces[i], &data.transverse_used);
        const ForceSensitivity& fs = cs.forces[i];
        Eigen::MatrixXd j(2, q);
        for (int a = 0; a < q; ++a) {
          const double th = theta[phys[a]];
          j(0, a) = th * fs.d_axial[a] / (scale * g.sigma_axial_um);
          j(1, a) = th * fs.d_transverse[a] / (scale * g.sigma_transverse_um);
        }
        const Eigen::MatrixXd m = Eigen::MatrixXd::Identity(q, q) + j.transpose() * j * fpost_inv;
        g.gain_nats = 0.5 * std::log(m.determinant());
        rep.candidates.push_back(g);
      }
      std::stable_sort(
          rep.candidates.begin(), rep.candidates.end(),
          [](const CandidateGain& a, const CandidateGain& b) { return a.gain_nats > b.gain_nats; });
    }
  }
  rep.wall_s = seconds_since(t0);
  return rep;
}

std::vector<std::string> IdentifiabilityReport::lines() const {
  std::vector<std::string> out;
  if (status != "ok" && combinations.empty()) {
    out.push_back("identifiability: " + status);
    return out;
  }
  std::ostringstream head;
  head << "identifiability at ";
  if (!point_label.empty()) head << point_label << " (";
  for (size_t k = 0; k < names.size() && k < at.size(); ++k)
    head << (k ? ", " : "") << names[k] << " " << std::setprecision(4) << at[k];
  if (!point_label.empty()) head << ")";
  head << "; Gauss-Newton Fisher information in log parameters, 1-sigma from the data alone:";
  out.push_back(head.str());
  for (size_t e = 0; e < combinations.size(); ++e) {
    const IdentifiedCombination& c = combinations[e];
    out.push_back("  " + c.text + ": " + percent(c.sd_log));
  }
  if (mu_relative_sd > 0) {
    std::ostringstream s;
    s << "  mu = " << std::setprecision(3) << mu_uN_per_m << " uN/m to " << std::setprecision(2)
      << 100 * mu_relative_sd << " %, K = " << std::setprecision(3) << k_uN_per_m << " uN/m to "
      << std::setprecision(2) << 100 * k_relative_sd
      << " % (with the prior box); best-determined combination vs log mu: |cos| = "
      << std::setprecision(3) << mu_alignment;
    out.push_back(s.str());
    if (mu_alignment > 0.95 && combinations.size() > 1) {
      bool rest_loose = false;
      for (size_t e = 1; e < combinations.size(); ++e)
        if (combinations[e].sd_log > 0.5) rest_loose = true;
      if (rest_loose)
        out.push_back("  the data determine mu; the other combinations are left to the prior");
    }
  }
  if (!candidates.empty()) {
    out.push_back("  expected information gain of one more point (D_A, D_T) per candidate force:");
    for (const auto& g : candidates) {
      std::ostringstream s;
      s << "    " << std::setprecision(4) << g.force_pN << " pN: " << std::setprecision(3)
        << g.gain_nats << " nats";
      out.push_back(s.str());
    }
  }
  if (status != "ok") out.push_back("  note: " + status);
  return out;
}

nlohmann::json IdentifiabilityReport::to_json() const {
  using nlohmann::json;
  json j;
  j["status"] = status;
  j["point"] = point_label;
  j["parametrisation"] = "log of each parameter (natural units: nm, nm, J, 1, 1)";
  j["fisher_information"] =
      "Gauss-Newton J' J of the whitened residuals (D_model - D_data)/(sigma_scale sigma); "
      "sigma-scale: 2 per Gaussian term, uncoupled";
  json at_j = json::object();
  for (size_t k = 0; k < names.size() && k < at.size(); ++k) at_j[names[k]] = at[k];
  j["at"] = at_j;
  j["names"] = names;
  json f = json::array();
  for (Eigen::Index a = 0; a < fisher_log.rows(); ++a) {
    json row = json::array();
    for (Eigen::Index b = 0; b < fisher_log.cols(); ++b) row.push_back(fisher_log(a, b));
    f.push_back(row);
  }
  j["fisher_log"] = f;
  json cs = json::array();
  for (const auto& c : combinations) {
    json coef = json::object();
    for (size_t k = 0; k < names.size(); ++k) coef[names[k]] = c.coefficients[k];
    cs.push_back({{"combination", c.text},
                  {"coefficients_of_log", coef},
                  {"eigenvalue", c.eigenvalue},
                  {"sd_log", std::isfinite(c.sd_log) ? json(c.sd_log) : json(nullptr)},
                  {"relative_precision_percent",
                   std::isfinite(c.sd_log) ? json(100 * c.sd_log) : json(nullptr)}});
  }
  j["combinations"] = cs;
  j["derived"] = {{"mu_uN_per_m", mu_uN_per_m},
                  {"mu_relative_sd", mu_relative_sd},
                  {"K_uN_per_m", k_uN_per_m},
                  {"K_relative_sd", k_relative_sd},
                  {"best_combination_alignment_with_log_mu", mu_alignment},
                  {"note",
                   "relative 1-sigma from the Fisher information plus the prior box's "
                   "(variance w^2/12 of a uniform box of log-width w)"}};
  json cand = json::array();
  for (const auto& g : candidates)
    cand.push_back({{"force_pN", g.force_pN},
                    {"gain_nats", g.gain_nats},
                    {"sigma_axial_um", g.sigma_axial_um},
                    {"sigma_transverse_um", g.sigma_transverse_um}});
  j["candidate_forces"] = cand;
  j["candidate_gain"] =
      "1/2 log det(I + F_new F_post^-1) over the physical parameters, F_post = Fisher + prior "
      "box; the new point's sigmas: the data's interpolated in force, times sigma-scale";
  j["lines"] = lines();
  j["wall_s"] = wall_s;
  return j;
}

void write_identifiability(const IdentifiabilityReport& r, const std::string& dir) {
  write_text_atomic(dir + "/identifiability.json", r.to_json().dump(2) + "\n");
}

}  // namespace rbc
