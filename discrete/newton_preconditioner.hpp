// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Prepared state of the stretch's Newton-type preconditioner: the network Hessian
// (discrete/network_hessian.hpp) factorised by core/sparse_cholesky.hpp (CHOLMOD, supernodal,
// symbolic analysis done once per network), plus the augmented-Lagrangian penalties' rank-two part
// applied by Sherman-Morrison-Woodbury. Used as L-BFGS's initial inverse Hessian (core/lbfgs.hpp).
// With a mirror symmetry (core/mirror_symmetry.hpp) it preconditions the problem on the
// symmetric states x = P q: it factorises P'HP and applies the Woodbury correction with P'U.
#include <memory>

#include "core/mirror_symmetry.hpp"
#include "core/sparse_cholesky.hpp"  // FillOrdering
#include "discrete/network_hessian.hpp"

namespace rbc {

/// Which matrix refresh() factorises.
enum class HessianChoice {
  /// The element-wise projected Hessian (always semidefinite; overestimates the stiffness of
  /// modes where elements under compression cancel elements under tension).
  projected,
  /// The exact Hessian (+ shift) when its Cholesky factorisation succeeds (near a stable
  /// equilibrium: Newton's quadratic convergence), else the projected one.
  exact_when_definite,
};

struct NewtonPreconditionerOptions {
  NetworkHessianOptions hessian;
  HessianChoice choice = HessianChoice::exact_when_definite;
  FillOrdering ordering = FillOrdering::metis;
  /// BLAS (OpenBLAS and OpenMP) threads of the factorisation and solves
  /// (core/blas_threads.hpp); 0 = the caller's. One is the default: CHOLMOD's many small
  /// BLAS calls scale poorly and collapse on a loaded machine, and one thread keeps the
  /// rounding independent of the core count.
  int blas_threads = 1;
  /// CHOLMOD's simplicial LL' (no BLAS) below this many unknowns (3N, or the reduced
  /// problem's), supernodal from it
  /// on (0 = always supernodal: measured faster from 750 unknowns on, once BLAS runs on one
  /// thread).
  int supernodal_min_unknowns = 0;
  /// Precision of the preconditioner's factorisation and solves (core/sparse_cholesky.hpp).
  /// Single for both by default. The solves read the whole factor twice per L-BFGS iteration
  /// and are bound by memory traffic: in float they take 24 instead of 34-44 ms at N = 27,042
  /// (3.2e7 factor entries) and 0.32 instead of 0.57 ms at N = 1,962 (`rbc bench stretch
  /// --benchmark_filter=preconditioner_apply`). The factorisation is bound by the dense
  /// kernels' rate, twice as high in float: `rbc bench sweep` row
  /// discrete/88pN_from_0pN/27500/0 5.8-6.6 s in double, 3.8-4.4 s in single precision. A
  /// preconditioner needs no more accuracy: it is the exact inverse of a matrix within float
  /// rounding of the Hessian (relative error ~ cond 1e-7 and the fronts' sizes; measured on the
  /// mirror-reduced N = 252 matrix, cond 7.8e3: 8e-7 with the double factor rounded, 1.2e-5
  /// factorised in float).
  SolvePrecision solve_precision = SolvePrecision::single_precision_factorisation;
};

class NewtonPreconditioner {
 public:
  NewtonPreconditioner(const Network& net, const NewtonPreconditionerOptions& options = {});
  /// On the symmetric states x = P q of `reduction` (a reduction of net's 3N coordinates):
  /// refresh() factorises P'HP + P'U K U'P, apply() acts on reduced vectors (reduced_size).
  /// nullptr or the trivial group: the full problem, as the constructor above.
  NewtonPreconditioner(const Network& net, const NewtonPreconditionerOptions& options,
                       std::shared_ptr<const SymmetryReduction> reduction);
  ~NewtonPreconditioner();
  NewtonPreconditioner(const NewtonPreconditioner&) = delete;
  NewtonPreconditioner& operator=(const NewtonPreconditioner&) = delete;

  /// Assembles the Hessian at x (feasible, 3 x N um; symmetric when reduced) with the
  /// augmented-Lagrangian state (multipliers, penalty stiffness scale) and factorises it (or
  /// P'HP). Returns false when the factorisation fails (then apply() is the identity).
  bool refresh(const Positions& x, const ConstraintMultipliers& lambda, double stiffness_scale);
  /// Changes only the penalty stiffness scale of the Woodbury correction (cheap).
  void set_stiffness_scale(double stiffness_scale);
  /// v <- M^{-1} v, M = Hessian + U diag(k_A, k_V) U^T, U = [dA/dx, dV/dx] at the refresh x
  /// (3N entries; reduced: M = P'HP + P'U diag(k_A, k_V) U'P, v of reduced_size entries).
  void apply(Eigen::VectorXd& v) const;
  bool ready() const;

  struct Statistics {
    int factorisations = 0;
    int exact_factorisations = 0;  ///< of which the exact (unprojected) Hessian
    int failed_attempts = 0;       ///< numeric factorisations that found the matrix indefinite
    int analyses = 0;              ///< symbolic analyses (ordering): one per network
    double assembly_s = 0, factorisation_s = 0, solve_s = 0;  ///< accumulated wall time
    /// The same on the calling thread's CPU clock (the factorisation and the solves run on
    /// it alone with one BLAS thread; assembly also uses the OpenMP team).
    double assembly_cpu_s = 0, factorisation_cpu_s = 0, solve_cpu_s = 0;
    double analysis_cpu_s = 0;   ///< of factorisation_cpu_s: the symbolic analyses
    double factor_nonzeros = 0;  ///< nonzeros of the Cholesky factor L
    int unknowns = 0;            ///< order of the factorised matrix: 3N, or q's entries
  };
  const Statistics& statistics() const;
  /// Serves net from now on, a network of the same mesh and bending law (another parameter
  /// set): the factorisation is kept, refresh() assembles net's Hessian (NetworkHessian::
  /// rebind; std::invalid_argument for another mesh or law, or custom terms). The network it
  /// served before is not read (it may be gone).
  void rebind(const Network& net);
  /// Whether it works on the mirror-reduced unknowns.
  bool reduced() const;
  /// The reduction it works on (nullptr: the full problem).
  const SymmetryReduction* reduction() const;
  /// The network Hessian refresh() assembles (3N x 3N, its pattern fixed per network). Its
  /// values may be overwritten between refreshes (e.g. by NetworkHessian::assemble_exact for
  /// the stretch's symmetry check): the factorisation does not read them again.
  NetworkHessian& hessian();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rbc
