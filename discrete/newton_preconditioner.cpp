// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/newton_preconditioner.hpp"

#include <chrono>
#include <stdexcept>

#include "core/cpu_time.hpp"

#include "core/geometry.hpp"
#include "core/parallel.hpp"

namespace rbc {

namespace {

/// Wall and calling-thread CPU clocks started together (statistics only).
struct Stopwatch {
  std::chrono::steady_clock::time_point wall = std::chrono::steady_clock::now();
  double cpu = thread_cpu_seconds();
  /// Adds the wall and CPU seconds since the start (or the last lap) and restarts.
  void lap(double& wall_s, double& cpu_s) {
    const auto now = std::chrono::steady_clock::now();
    const double c = thread_cpu_seconds();
    wall_s += std::chrono::duration<double>(now - wall).count();
    cpu_s += c - cpu;
    wall = now;
    cpu = c;
  }
};

/// The factorisation's options: the preconditioner's ordering, threads and switch, and
/// CHOLMOD's own supernode amalgamation at every size.
SparseCholeskyOptions cholesky_options(const NewtonPreconditionerOptions& o) {
  SparseCholeskyOptions c;
  c.ordering = o.ordering;
  c.supernodal_min_unknowns = o.supernodal_min_unknowns;
  c.blas_threads = o.blas_threads;
  c.relaxed_amalgamation_below = 0;
  c.solve_precision = o.solve_precision;
  return c;
}

}  // namespace

struct NewtonPreconditioner::Impl {
  const Network* net;
  NetworkHessian hessian;
  /// Mirror reduction x = P q (null: the full problem) and the P'HP map of the Hessian's
  /// pattern (built on the first refresh).
  std::shared_ptr<const SymmetryReduction> reduction;
  std::unique_ptr<ReducedMatrix> reduced;
  HessianChoice choice;
  SparseCholesky factor;  ///< of the (reduced) Hessian, analysed once
  bool analysed = false, factored = false;
  Eigen::MatrixXd u, z;  ///< 3N (or reduced) x 2: constraint gradients (P'U) and M^{-1} U
  Eigen::Matrix2d utz = Eigen::Matrix2d::Zero(), m_inv = Eigen::Matrix2d::Zero();
  double stiffness_scale = 1.0;  ///< of m_inv (set_stiffness_scale)
  mutable Statistics stats;

  Impl(const Network& n, const NewtonPreconditionerOptions& o,
       std::shared_ptr<const SymmetryReduction> r)
      : net(&n),
        hessian(n, o.hessian),
        reduction(r && !r->trivial() ? std::move(r) : nullptr),
        choice(o.choice),
        factor(cholesky_options(o)) {
    if (reduction && reduction->full_size != 3 * n.topo.num_vertices)
      throw std::invalid_argument("NewtonPreconditioner: the reduction is not of this network");
    stats.unknowns = reduction ? reduction->reduced_size : 3 * n.topo.num_vertices;
  }
};

NewtonPreconditioner::NewtonPreconditioner(const Network& net,
                                           const NewtonPreconditionerOptions& options)
    : impl_(std::make_unique<Impl>(net, options, nullptr)) {}

NewtonPreconditioner::NewtonPreconditioner(const Network& net,
                                           const NewtonPreconditionerOptions& options,
                                           std::shared_ptr<const SymmetryReduction> reduction)
    : impl_(std::make_unique<Impl>(net, options, std::move(reduction))) {}

NewtonPreconditioner::~NewtonPreconditioner() = default;

bool NewtonPreconditioner::ready() const {
  return impl_->factored;
}

const NewtonPreconditioner::Statistics& NewtonPreconditioner::statistics() const {
  return impl_->stats;
}

void NewtonPreconditioner::rebind(const Network& net) {
  impl_->hessian.rebind(net);
  impl_->net = &net;
  if (impl_->factored) set_stiffness_scale(impl_->stiffness_scale);
}

bool NewtonPreconditioner::reduced() const {
  return static_cast<bool>(impl_->reduction);
}

const SymmetryReduction* NewtonPreconditioner::reduction() const {
  return impl_->reduction.get();
}

NetworkHessian& NewtonPreconditioner::hessian() {
  return impl_->hessian;
}

bool NewtonPreconditioner::refresh(const Positions& x, const ConstraintMultipliers& lambda,
                                   double stiffness_scale) {
  Impl& s = *impl_;
  const Network& net = *s.net;
  const int n = net.topo.num_vertices;
  Stopwatch clock;
  // Constraint gradients and the tension/pressure of the augmented Lagrangian at x.
  Positions ga = Positions::Zero(3, n), gv = Positions::Zero(3, n);
  const Topology& t = net.topo;
  const double area = assemble_parallel(t.num_faces(), &ga, [&](int f, Positions& g) {
    Eigen::Matrix3d gf;
    const double a =
        triangle_area(x.col(t.faces(0, f)), x.col(t.faces(1, f)), x.col(t.faces(2, f)), &gf);
    for (int k = 0; k < 3; ++k) g.col(t.faces(k, f)) += gf.col(k);
    return a;
  });
  const double volume = assemble_parallel(t.num_faces(), &gv, [&](int f, Positions& g) {
    Eigen::Matrix3d gf;
    const double v =
        tetra_volume(x.col(t.faces(0, f)), x.col(t.faces(1, f)), x.col(t.faces(2, f)), &gf);
    for (int k = 0; k < 3; ++k) g.col(t.faces(k, f)) += gf.col(k);
    return v;
  });
  ConstraintCurvature cc;
  cc.tension_pN_per_um = lambda.area_pN_per_um + stiffness_scale *
                                                     net.constraints.area_stiffness_pN_per_um3 *
                                                     (area - net.area0_um2);
  cc.pressure_pN_per_um2 =
      lambda.volume_pN_per_um2 +
      stiffness_scale * net.constraints.volume_stiffness_pN_per_um5 * (volume - net.volume0_um3);
  clock.lap(s.stats.assembly_s, s.stats.assembly_cpu_s);
  auto factorise = [&](bool project) {
    const Eigen::SparseMatrix<double>* hp = &s.hessian.assemble(x, cc, project);
    if (s.reduction) {  // P'HP (the projection counts as assembly)
      if (!s.reduced) s.reduced = std::make_unique<ReducedMatrix>(*s.reduction, *hp);
      hp = &s.reduced->reduce(*hp);
    }
    const Eigen::SparseMatrix<double>& h = *hp;
    clock.lap(s.stats.assembly_s, s.stats.assembly_cpu_s);
    if (!s.analysed) {
      const double analysis_start_cpu_s = thread_cpu_seconds();
      s.factor.analyze(h);
      s.analysed = true;
      s.stats.factor_nonzeros = s.factor.factor_nonzeros();
      s.stats.analysis_cpu_s += thread_cpu_seconds() - analysis_start_cpu_s;
    }
    const bool ok = s.factor.factorize(h);
    // Counted by the factorisation itself: one factorize() makes on a changed pattern counts too
    // (and then changes the factor's size).
    if (s.factor.analyses() != s.stats.analyses) {
      s.stats.analyses = s.factor.analyses();
      s.stats.factor_nonzeros = s.factor.factor_nonzeros();
    }
    clock.lap(s.stats.factorisation_s, s.stats.factorisation_cpu_s);
    if (!ok) ++s.stats.failed_attempts;
    return ok;
  };
  s.factored = false;
  if (s.choice == HessianChoice::exact_when_definite) {
    s.factored = factorise(false);
    if (s.factored) ++s.stats.exact_factorisations;
  }
  if (!s.factored) s.factored = factorise(true);
  if (s.factored) {
    s.u.resize(3 * n, 2);
    s.u.col(0) = flat(ga);
    s.u.col(1) = flat(gv);
    if (s.reduction) s.u = reduce(*s.reduction, s.u);  // P'U
    s.z = s.factor.solve(s.u);
    s.utz = s.u.transpose() * s.z;
    ++s.stats.factorisations;
    set_stiffness_scale(stiffness_scale);
  }
  clock.lap(s.stats.factorisation_s, s.stats.factorisation_cpu_s);
  return s.factored;
}

void NewtonPreconditioner::set_stiffness_scale(double scale) {
  Impl& s = *impl_;
  s.stiffness_scale = scale;
  Eigen::Matrix2d m = s.utz;
  m(0, 0) += 1.0 / (scale * s.net->constraints.area_stiffness_pN_per_um3);
  m(1, 1) += 1.0 / (scale * s.net->constraints.volume_stiffness_pN_per_um5);
  s.m_inv = m.inverse();
}

void NewtonPreconditioner::apply(Eigen::VectorXd& v) const {
  const Impl& s = *impl_;
  if (!s.factored) return;
  Stopwatch clock;
  // (M + U K U^T)^{-1} v = w - Z (K^{-1} + U^T Z)^{-1} U^T w,  w = M^{-1} v, Z = M^{-1} U
  // (reduced: M = P'HP and U = P'U).
  v = s.factor.solve(v);
  const Eigen::Vector2d utv = s.u.transpose() * v;
  v -= s.z * (s.m_inv * utv);
  clock.lap(s.stats.solve_s, s.stats.solve_cpu_s);
}

}  // namespace rbc
