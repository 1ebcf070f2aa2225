// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Parameter sensitivities of the optical-tweezers stretch (the forward model of the
// calibration, calibrate/forward_model.hpp) by the implicit function theorem, the gradient of
// the calibration's log-likelihood through them, and the identifiability report of `rbc infer`.
//
// Sensitivities. At a converged constrained equilibrium x(theta), lambda(theta) of
//   L(x, lambda; theta) = E(x; theta) + lambda_A (A(x) - A0) + lambda_V (V(x) - V0)
// (continuum/newton_solver.hpp; A0, V0 are the rest mesh's and do not depend on theta),
// differentiating grad_x L = 0, A = A0, V = V0 in theta gives the bordered system
//   [H  C] [dx/dtheta     ]     [d(grad_x E)/dtheta]
//   [C' 0] [dlambda/dtheta] = - [0                 ],   C = [grad A, grad V] (3N x 2),
// with H = d2L the exact, unshifted Hessian of the Lagrangian at the solution (in-plane law,
// bending and lambda_A d2A + lambda_V d2V; add_lagrangian_hessian), the multiplier rows
// included. The continuum model holds area and volume by exact multipliers, so there is no
// penalty term to add. The mixed derivative d(grad_x E)/dtheta is a central difference of the
// energy gradient in theta at the fixed equilibrium x (two gradient evaluations per parameter,
// relative step SensitivityOptions::relative_step, no solve; truncation ~1e-8 relative). The
// system is solved by projected preconditioned conjugate gradients on the tangent space
// C' dx = 0 (Gould, Hribar & Nocedal 2001) with the exact H as operator and the factorisation
// of K = H + sigma s I (core/sparse_cholesky.hpp; s = mean |H_ii|, sigma from 1e-8 up by 10x
// until K is positive definite) with the 2 x 2 Schur complement C' K^-1 C as the constraint
// preconditioner: one factorisation per force, then a few solves per parameter. Only the
// reduced Hessian (H on the tangent space) need be positive definite, as at a stable
// equilibrium; where lambda_A d2A makes H indefinite off the tangent space the shift grows and
// CG takes more iterations, with the same answer.
//
// Rigid modes: E, A and V are invariant under the 3 translations and the rotation about the
// stretch axis x, so H has these 4 null vectors, which the right-hand side and C are
// orthogonal to. The CG iterates stay orthogonal to them, and the result is projected onto
// their orthogonal complement (translations and the rotation about the centroid's x-axis):
// the sensitivity of the minimum-norm solution. D_A and D_T do not depend on these modes
// (D_A is the x extent, D_T the largest distance between two vertices projected on the y-z
// plane), and on the mirror-symmetric equilibria the forward model solves by default the
// derivative is mirror-symmetric and so orthogonal to the rotation, as the symmetry pins it.
// With the forward model's mirror reduction (NewtonOptions::symmetry = mirror, the default) and
// an equilibrium symmetric under the mirrors of the mesh that keep the bead load (to 1e-8 um),
// the system is solved on the symmetric subspace u = P q (core/mirror_symmetry.hpp,
// continuum/reduced_hessian.hpp): P'HP q + P'C dlambda = -P'b, C'P q = 0, whose solution is
// the full system's (the parameters keep the symmetry, so the derivative is symmetric), at
// about 1/|G| of the unknowns; the rigid modes left there (those symmetric under the group)
// are deflated as above. A buckled (asymmetric) equilibrium, or Symmetry::none, is solved in
// full (3N unknowns).
//
// Maxima over vertices: D_A = max x - min x and D_T = the largest distance between two
// projected vertices (core/geometry.hpp measure_diameters). Their derivatives here are those
// of the currently extremal vertices (the pair attaining each maximum): the derivative of the
// forward model's own observable wherever the extremal vertices are unique, so the gradient is
// that of the likelihood TMCMC samples. Where the extremal vertex (pair) changes as theta
// moves, D is continuous but its derivative jumps from one pair's value to the other's (a
// kink; the likelihood is then Lipschitz, not differentiable, along that surface of theta).
//
// The derivative is that of the exact equilibrium. The forward model stops at a net vertex
// force of 1e-4 pN (ForwardOptions), so where a parameter's effect on the forces stays below
// that, its diameters do not move at all: at 0 pN (the rest shape, nearly stress-free) a
// persistence change of 1 % changes no diameter of a warm-started run, where the exact
// derivative is 0.0024 um/nm (2,000 elements, p = 22.7 nm, Lmax = 161 nm).
//
// Cost, measured at the default calibration (continuum:2:2000, the 13 Mills forces, p and
// Lmax, one thread on a loaded 2-core machine, medians of 5): 0.12 s for all sensitivities
// (central differences 0.03, reduced Hessians 0.035, factorisations 0.027, CG solves 0.015),
// against 0.077 s for a forward run warm-started from a parent 1 % away and 0.165 s for a cold
// one; on the full problem (no reduction) 0.49 s.
//
// The discrete forward model (MethodKind::discrete) is covered by the same bordered system on
// the network: H is its exact Hessian (discrete/network_hessian.hpp assemble_exact: links and
// steric unprojected, Juelicher bending with the hinge curvature term) plus the constraint
// curvature, and the mixed derivative is the central difference of the gradient of every term
// but the area/volume penalty. The network's augmented-Lagrangian state carries multipliers
// and a penalty whose sum is the tension and pressure, so the multipliers used are the exact
// ones of the state, lambda = argmin |grad E + C lambda| (equal to the constrained problem's at
// an equilibrium). The network is solved in full (its forward runs use no mirror reduction).
// Measured against central differences of tightly solved network equilibria (N = 92, 25 and
// 80 pN, p, Lmax, kappa, contact fraction): observed order 2 (error ratios 3.9-4.1 per halving)
// down to 1e-10 um.
#include <Eigen/Core>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "calibrate/forward_model.hpp"
#include "calibrate/infer.hpp"
#include "calibrate/prior_spec.hpp"

namespace rbc {

struct SensitivityOptions {
  /// Relative step of the central difference of the energy gradient in each parameter
  /// (h = relative_step x |theta_k|).
  double relative_step = 1e-4;
  /// Projected CG: stop when the preconditioned residual has fallen by cg_tolerance (relative
  /// error of dx in the preconditioner's norm); at most max_cg_iterations per parameter.
  double cg_tolerance = 1e-8;
  int max_cg_iterations = 500;
  /// Drops the multiplier rows and columns of the bordered system (dx from H dx = -b alone,
  /// the constraints free): wrong on purpose, for the tests' mutation check only.
  bool drop_multiplier_rows = false;
  void validate() const;  ///< throws std::invalid_argument naming the value
};

/// The sensitivities at one force; derivatives per natural unit of each parameter (nm, nm, J,
/// 1: the units of `rbc infer --params`), in the order of StretchSensitivities::parameters.
struct ForceSensitivity {
  double force_pN = 0;
  double axial_um = 0, transverse_um = 0;     ///< D_A, D_T at the equilibrium
  std::vector<double> d_axial, d_transverse;  ///< dD_A/dtheta_k, dD_T/dtheta_k (um per unit)
  std::vector<double> d_area_multiplier;      ///< dlambda_A/dtheta_k (pN/um per unit)
  std::vector<double> d_volume_multiplier;    ///< dlambda_V/dtheta_k (pN/um^2 per unit)
  int axial_vertices[2] = {-1, -1};           ///< largest and smallest x
  int transverse_vertices[2] = {-1, -1};      ///< the pair whose distance is D_T
  double residual_pN = 0;  ///< largest net vertex force of grad_x L at the given state
  double shift = 0;        ///< sigma of the factorised K = H + sigma s I (relative to s)
  int cg_iterations = 0;   ///< summed over the parameters
  bool cg_converged = true;
  bool reduced = false;  ///< solved on the mirror-symmetric subspace (below)
};

struct StretchSensitivities {
  std::vector<Parameter> parameters;  ///< physical parameters differentiated
  std::vector<ForceSensitivity> forces;
  double mixed_s = 0, hessian_s = 0, factorise_s = 0, solve_s = 0;  ///< wall time of each part
  bool converged() const;                                           ///< every force's CG converged
};

/// Whether a parameter enters the stretch forward model (persistence, lmax, kappa,
/// contact-fraction; not sigma-scale, eta-m or tau).
bool is_forward_parameter(Parameter p);

/// The sensitivities of a forward model (same mesh or network as ForwardModel(options)).
class StretchSensitivity {
 public:
  /// Builds the rest mesh (or network) as ForwardModel does. Throws std::invalid_argument for
  /// invalid options.
  explicit StretchSensitivity(const ForwardOptions& options, const SensitivityOptions& s = {});
  ~StretchSensitivity();
  StretchSensitivity(const StretchSensitivity&) = delete;
  StretchSensitivity& operator=(const StretchSensitivity&) = delete;
  /// dD_A/dtheta, dD_T/dtheta at each force of `forces_pN` from the converged equilibria in
  /// `state` (ForwardRun::state of a run over those forces at `parameters`: per force 3N
  /// positions and the two multipliers). `wrt` lists the physical parameters (sigma-scale
  /// refused). Throws std::invalid_argument for a state that does not fit.
  StretchSensitivities compute(const ForwardParameters& parameters,
                               const std::vector<double>& forces_pN, const WarmState& state,
                               const std::vector<Parameter>& wrt) const;
  int vertices() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// log L (calibrate/likelihood.hpp) at theta (the problem's parameter slots, natural units) and
/// its gradient in theta (same units; sigma-scale and tau differentiated in closed form), by
/// the chain rule through the sensitivities at the forward runs' equilibria: one run per
/// forward-run group, each experiment's slots moving its own model only. Recovery experiments
/// add their term, its gradient and Gauss-Newton information in eta-m, persistence, lmax and kappa
/// (calibrate/recovery_likelihood.hpp recovery_gradient_and_information: 1 + 2 x the
/// differentiated stretch parameters release-scene trajectories each), and in eta-spread when
/// it is inferred (recovery_spread_gradient_and_information: the same trajectories, each cell
/// integrated over its own viscosity; its information the Fisher information of the Gaussian
/// approximation stated there); contact-fraction with
/// recovery data is refused (std::invalid_argument). The physical parameters'
/// entries are NaN where a sensitivity solve did not converge (sensitivities.converged()). `failed`
/// (log L = -inf, no gradient) for a forward run that did not converge; outside the prior box log L
/// is evaluated all the same (the caller applies the prior).
struct LikelihoodGradient {
  double log_likelihood = 0;
  std::vector<double> gradient;  ///< d log L / d theta_k
  bool failed = false;
  ModelDiameters diameters;            ///< the first forward-run group's (InferenceProblem)
  StretchSensitivities sensitivities;  ///< the first group's
  WarmState state;                     ///< the forward runs' equilibria (every group's)
  /// Gauss-Newton (expected Fisher) information of log L in theta (natural units): J' Sigma^-1 J
  /// of each experiment's Gaussian blocks for the physical parameters; for sigma-scale and tau
  /// 1/2 tr(Sigma^-1 dSigma_a Sigma^-1 dSigma_b), uncoupled from the physical ones.
  Eigen::MatrixXd information;
  double forward_s = 0, sensitivity_s = 0;  ///< wall time of the forward run and of the rest
  /// Release-scene trajectories run for recovery experiments (the centre and the central
  /// differences; calibrate/recovery_likelihood.hpp recovery_gradient_and_information).
  int recovery_trajectories = 0;
};
/// `sensitivity` must be built from problem.forward().options().
LikelihoodGradient log_likelihood_and_gradient(const InferenceProblem& problem,
                                               const StretchSensitivity& sensitivity,
                                               std::span<const double> theta,
                                               const WarmState& warm = {});

/// Identifiability of the parameters at a point (the posterior median): the Gauss-Newton
/// Fisher information F = J' J of the whitened residuals (D_model - D_data)/(c sigma) in log
/// parameters (log theta: each coordinate's precision is relative, and parameters of different
/// units combine; sigma-scale adds 2 per Gaussian term on its own diagonal, uncoupled from the
/// others), its eigen-decomposition as "which combinations of log parameters the data
/// determine and to what 1-sigma precision" (1/sqrt(eigenvalue), the data alone), and the
/// precision of the derived moduli mu and K through it. Candidate forces are ranked by the
/// D-optimal expected information gain of one more stretch point (D_A and D_T) at that force,
///   gain = 1/2 log det(I + F_new F_post^-1)  (nats),
/// with F_post = F + the prior box's information (a uniform box of width w in log theta has
/// variance w^2/12) over the physical parameters (sigma-scale's block is uncoupled and left
/// out), and the new point's error bars those of the data interpolated linearly in force
/// (constant beyond the ends) times the sigma scale.
struct IdentifiedCombination {
  std::vector<double> coefficients;  ///< unit vector over log parameters (names' order)
  double eigenvalue = 0;             ///< of F
  double sd_log = 0;                 ///< 1/sqrt(eigenvalue): 1-sigma of the combination
  std::string text;                  ///< e.g. "0.62 log persistence - 0.78 log lmax"
};
struct CandidateGain {
  double force_pN = 0;
  double gain_nats = 0;
  double sigma_axial_um = 0, sigma_transverse_um = 0;  ///< the error bars assumed
};
struct IdentifiabilityReport {
  std::string status = "ok";  ///< or why no report was made (e.g. "forward run failed")
  /// What the point is, for the heading of lines() (e.g. "the posterior median"); empty: the
  /// parameter values only.
  std::string point_label;
  std::vector<std::string> names;
  std::vector<double> at;                           ///< theta (natural units)
  Eigen::MatrixXd fisher_log;                       ///< F in log parameters
  std::vector<IdentifiedCombination> combinations;  ///< best determined first
  /// Relative 1-sigma of mu and K from F + the prior box's information (mu, K in closed form
  /// from p and Lmax, calibrate/infer.hpp sample_moduli), 0 when neither is inferred.
  double mu_relative_sd = 0, k_relative_sd = 0;
  /// |cos| of the angle between grad log mu and the best-determined combination.
  double mu_alignment = 0;
  double mu_uN_per_m = 0, k_uN_per_m = 0;
  std::vector<CandidateGain> candidates;  ///< ranked, largest gain first
  double wall_s = 0;
  /// Human-readable lines (the summary's).
  std::vector<std::string> lines() const;
  nlohmann::json to_json() const;
};
/// The report at theta (the problem's parameters, natural units); candidate_forces_pN may be
/// empty. A forward run at theta over the data's forces (and one over the candidates) is made.
IdentifiabilityReport identifiability(const InferenceProblem& problem,
                                      std::span<const double> theta,
                                      const std::vector<double>& candidate_forces_pN);
/// Writes DIR/identifiability.json atomically.
void write_identifiability(const IdentifiabilityReport& r, const std::string& dir);

}  // namespace rbc
