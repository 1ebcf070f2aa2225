// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The likelihood of shape-recovery data (Hochmuth, Worthy & Evans 1979: the length-over-width
// ratio lambda(t) of a cell released from extension) under the project's continuum dynamics
// (MODEL.md section 6), for the calibration.
//
// Hochmuth's measure r(t) = (lambda - lambda_inf)/(lambda + lambda_inf) is fitted in its
// NORMALISED form: the model gives the decay g(t) = r(t)/r(0) of lambda = D_A/D_T after the
// release of the tweezers' force F (the continuum release scene of `rbc dynamics`), and each
// cell keeps its own amplitude and limit, since the experiment's pipette geometry differs from
// the bead scene:
//   lambda_model(t) = lambda_inf (1 + r0 g(t))/(1 - r0 g(t)),  r0 = (lambda_0 - lambda_inf)/
//   (lambda_0 + lambda_inf),
// with lambda_0 and lambda_inf per cell nuisance parameters and Gaussian errors sigma_ratio on
// every lambda.
//
// Time rescaling. In the continuum release scene the only dissipation is the membrane's
// viscous potential, eta_m |dev M|^2 + eta_d/2 (tr M)^2 with eta_d = ratio x eta_m
// (continuum/membrane_viscosity.hpp), entering each backward-Euler step as (eta_m/dt) x (a
// function of x and x_n); the fluids are not modelled in the in-plane scenes (their share,
// ~4 %, is stated in continuum/dynamics.hpp) and no other term carries a time. So the step
// problem at (eta_m, dt) is the step problem at (eta_ref, dt eta_ref/eta_m): the trajectory at
// eta_m is the one at eta_ref with its clock stretched, g(t; eta_m) = g_ref(t eta_ref/eta_m),
// exactly for the time-continuous flow and, for the time-discrete one, up to the difference of
// time-stepping error between step dt and dt eta_ref/eta_m (the step tolerance aside). One
// trajectory per (p, Lmax, kappa, contact fraction) therefore serves every eta_m; the
// derivative in eta_m is analytic through the rescaling. This does not hold where a drag that
// is not proportional to eta_m enters (the relax scene's normal drag, or the fluids were they
// modelled). Tests: tests/calibrate/test_recovery_likelihood.cpp (a direct run at 2 eta_ref
// against the rescaled curve; the run at (2 eta_ref, 2 dt) is the eta_ref run to the last
// bit); the discrete scene's exact
// (eta_m, dt) -> (2 eta_m, 2 dt) identity is tests/app/test_cli_dynamics.cpp
// (CliDynamics.RecoveryTimeIsProportionalToTheMembraneViscosity).
//
// Nuisances: by default a Laplace approximation of their marginal (RecoveryNuisances::laplace)
// under a uniform prior on (lambda_inf, lambda_0) over a stated box, so the value is a
// log-evidence term comparable across models; profiling (the maximum over them) is available.
// Docs: docs/validation/recovery_likelihood.md.
//
// Cells with their own viscosity (optional; `rbc infer --params ...,eta-m,eta-spread`). Cell c
// has eta_c = eta_m exp(s eps_c), eps_c ~ N(0, 1) independent, s (dimensionless) the sd of
// log eta over cells, and its term is the marginal
//   log int L_c(eta_m e^{s eps}) phi(eps) d eps
// of its likelihood above (nuisances included) over its own viscosity. Every eta_c reads the
// same trajectory through the rescaling, so the integral costs no new simulation. It is taken
// by ADAPTIVE Gauss-Hermite quadrature (Liu & Pierce 1994): the nodes are centred at the
// integrand's mode in v = log eta_c and scaled by its curvature there, since a cell of 25
// readings fixes its log eta_c to ~0.05, much narrower than the spread of Gauss-Hermite nodes
// laid out for the prior N(0, 1) once s exceeds ~0.05 (there a fixed rule of 40 nodes misses
// the likelihood's peak altogether). Nodes and weights: GSL's gsl_integration_fixed_hermite.
// s = 0 is the shared-eta_m likelihood above.
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "calibrate/forward_model.hpp"
#include "core/mesh.hpp"
#include "discrete/wlc.hpp"

namespace rbc {

/// One cell's curve: time (s, increasing, >= 0) and length over width (> 0).
struct RecoveryCell {
  int id = 0;
  std::vector<double> time_s, length_over_width;
};

/// Recovery data of one or more cells.
struct RecoveryData {
  std::vector<RecoveryCell> cells;
  std::string path;           ///< the file read (empty when built in code)
  std::string content_hash;   ///< FNV-1a 64 (core/fnv1a.hpp) of the file's bytes, hexadecimal
  double sigma_ratio = 0.02;  ///< standard deviation of each reading of lambda (the files' +-0.02)
  int points() const;         ///< total over the cells
};

/// Reads data/hochmuth1979_recovery_cells.csv (columns cell,time_s,length_over_width) or the
/// single-cell data/hochmuth1979_recovery.csv (time_s,length_over_width: cell 1). '#' lines are
/// comments. Throws rbc::InvalidParameter naming the file and line (quantity "recovery data
/// file 'F' line N") for a header other than those two, a row of the wrong length, a value that
/// is not a finite number, a negative time, a ratio <= 0, a cell id that is not a positive
/// integer, a cell whose rows are not contiguous, times not increasing within a cell; and
/// (quantity "recovery data file 'F'") for a file that cannot be read or a cell with fewer than
/// 3 points. sigma_ratio is the default 0.02.
RecoveryData read_recovery_data(const std::string& path);

/// The release scene the likelihood runs (continuum model): the equilibria at F and at 0 by
/// the static solver, then backward Euler at F = 0 from the loaded equilibrium.
struct RecoveryModelOptions {
  /// Continuum triangles, [kMinContinuumElements, kMaxContinuumElements]. Measured on the
  /// Hochmuth cells (docs/validation/recovery_likelihood.md): the eta_m maximum moves 1.5 % from
  /// 400 to 1,000 elements and 2.4 % from 1,000 to 2,000; 1.4 s CPU per curve at 1,000.
  int elements = 1000;
  WlcExpansion order = WlcExpansion::order2;  ///< in-plane law, as the calibration's default
  /// Reference membrane viscosity eta_ref (pN s/um, > 0) of the one trajectory.
  double eta_ref_pN_s_per_um = 0.7;
  double dilatational_ratio = 2.0;  ///< eta_d/eta_m (>= 0), the network's value
  /// Released force F (pN), in (0, kMaxContinuumForce_pN]. 100 pN gives lambda(0) ~ 2 at the
  /// paper's parameters, the amplitude of Hochmuth's cells (the decay's shape depends on it
  /// through the law's nonlinearity).
  double release_force_pN = 100.0;
  /// Time step at eta_ref (s), in (0, duration_s]. With the extrapolation g is within 1e-4 of
  /// the dt -> 0 curve at 2.5 ms; at 5 ms the coarse 10 ms run's solution path changed
  /// discretely with kappa (a jump of 4e-5 in g), which spoils finite differences in the
  /// parameters.
  double dt_s = 0.0025;
  /// Simulated time at eta_ref (s), > 0: the data's last time t_max reads the tail beyond it
  /// (RecoveryCurve::at) for eta_m < eta_ref t_max/duration.
  double duration_s = 0.45;
  /// Richardson extrapolation of the first-order backward Euler: the curve is 2 g_dt - g_2dt
  /// on the 2 dt grid (one more run at 2 dt, half the cost of the first), error O(dt^2).
  bool richardson = true;
  double step_tolerance_pN_per_s = 1.0;  ///< backward-Euler step force tolerance per dt, > 0
  /// Throws rbc::InvalidParameter naming the quantity ("elements", "reference viscosity
  /// eta_ref", "dilatational ratio eta_d/eta_m", "release force", "time step dt", "duration",
  /// "step tolerance").
  void validate() const;
};

/// The model's normalised recovery at eta_ref: g(t) = r(t)/r(0) at reference times.
struct RecoveryCurve {
  std::vector<double> time_s;  ///< reference times at eta_ref (s), from 0, increasing
  std::vector<double> shape;   ///< g at time_s; shape[0] = 1
  std::vector<double> lambda;  ///< the model's D_A/D_T at time_s (Richardson-combined)
  double lambda_inf = 1.0;     ///< D_A/D_T at the zero-force equilibrium
  /// Shear modulus mu (pN/um = uN/m; closed form of the WLC and steric parameters): the
  /// Kelvin-Voigt time is eta_m/mu.
  double shear_modulus_pN_per_um = 0;
  double eta_ref_pN_s_per_um = 0.7;
  /// Static solves and trajectory (both, with Richardson) converged, with at least 3 samples.
  bool converged = false;
  std::string status;  ///< why not, in words; "converged" otherwise
  double cpu_s = 0;    ///< CPU time of the simulating thread (s)
  /// Steps of the trajectories that needed halving (a halved step changes the discretisation
  /// locally, so the curve jumps by ~dt^2 where a parameter change starts or stops one).
  int halved_steps = 0;

  /// g(t) at reference time t >= 0 (s): cubic Hermite interpolation of log g with the slopes of
  /// the parabolas through neighbouring samples (exact for an exponential); beyond the last
  /// sample (the trajectory's end, or the last sample before g < 1e-3, where log g is the
  /// solver's noise) the exponential continued at the last sample's rate (not increasing).
  /// g_prime (1/s): dg/dt there, when given. Throws std::invalid_argument for fewer than 3
  /// samples.
  double at(double t_ref_s, double* g_prime = nullptr) const;
  /// Hochmuth's t_c of the curve at eta_m (s): the least-squares exponential fit of
  /// discrete/dynamics.hpp's fit_recovery (window down to 0.1 r(0)) at eta_ref, times
  /// eta_m/eta_ref. 0 when the fit is not valid.
  double recovery_time_s(double eta_m_pN_s_per_um) const;
};

/// The release scene for many parameter sets: the mesh is built once (on one thread, as the
/// forward model's), simulate() may run from several threads at once and depends on its
/// arguments alone for a given OpenMP thread count of its inner solvers (run it on one thread
/// inside a sampler's executor, as the forward model).
class RecoveryModel {
 public:
  explicit RecoveryModel(const RecoveryModelOptions& options);  ///< validates
  /// One trajectory (two with Richardson) at `parameters` (p, Lmax, kappa, contact fraction:
  /// the smooth bead patch of the forward model). A solve that fails gives converged false.
  RecoveryCurve simulate(const ForwardParameters& parameters) const;
  const RecoveryModelOptions& options() const { return options_; }

 private:
  RecoveryModelOptions options_;
  TriMesh mesh_;
};

/// RecoveryModel(options).simulate(parameters).
RecoveryCurve simulate_recovery(const ForwardParameters& parameters,
                                const RecoveryModelOptions& options);

/// How the per-cell nuisances (lambda_0, lambda_inf) enter.
enum class RecoveryNuisances {
  /// Laplace approximation of the marginal over the uniform prior box (Gauss-Newton Hessian
  /// at the conditional mode): a log-evidence term.
  laplace,
  /// The maximum over them (profile likelihood): no prior, not an evidence.
  profile,
};

struct RecoveryLikelihoodOptions {
  RecoveryNuisances nuisances = RecoveryNuisances::laplace;
  /// Uniform prior of lambda_inf and of lambda_0, each on [lambda_min, lambda_max] (Laplace
  /// only; the mode is assumed inside, where the box's edges do not matter).
  double lambda_min = 1.0, lambda_max = 4.0;
  void validate() const;  ///< 0 < lambda_min < lambda_max, finite (rbc::InvalidParameter)
};

/// One cell's nuisances at their conditional mode.
struct RecoveryCellFit {
  int id = 0;
  double lambda_0 = 0, lambda_inf = 0, r0 = 0;
  double chi2 = 0;         ///< sum ((lambda_model - lambda)/sigma)^2 at the mode
  double log_term = 0;     ///< this cell's share of log_likelihood
  bool converged = false;  ///< the nuisance fit converged
};

struct RecoveryLikelihood {
  /// log p(data | theta, eta_m): profile or Laplace-marginal over the nuisances, Gaussian
  /// normalisation included; -inf when a cell's fit fails or the curve did not converge.
  double log_likelihood = 0;
  /// d log_likelihood / d eta_m (per pN s/um), analytic through the rescaling (the nuisance
  /// modes' dependence on eta_m included for the Laplace determinant).
  double dlog_deta_per_pN_s_per_um = 0;
  std::vector<RecoveryCellFit> cells;
};

/// The likelihood of `data` at membrane viscosity eta_m (pN s/um, > 0) given the model's curve:
/// data time t is reference time t eta_ref/eta_m.
RecoveryLikelihood evaluate_recovery_likelihood(const RecoveryCurve& curve,
                                                double eta_m_pN_s_per_um, const RecoveryData& data,
                                                const RecoveryLikelihoodOptions& options = {});
/// evaluate_recovery_likelihood(...).log_likelihood.
double recovery_log_likelihood(const RecoveryCurve& curve, double eta_m_pN_s_per_um,
                               const RecoveryData& data,
                               const RecoveryLikelihoodOptions& options = {});

/// Gradient of the log-likelihood: eta_m analytic; p, Lmax and kappa by central differences of
/// whole trajectories (relative step `relative_step` of each parameter, 6 more simulations),
/// an approximation whose error is the step's O(h^2) plus the trajectories' solver noise over h.
struct RecoveryGradient {
  double log_likelihood = 0;
  double d_eta_per_pN_s_per_um = 0;
  double d_persistence_per_nm = 0, d_lmax_per_nm = 0, d_kappa_per_J = 0;
  bool converged = false;
  /// d log_likelihood / d s, the between-cell sd of log eta (recovery_spread_gradient_and_
  /// information only; 0 otherwise).
  double d_spread = 0;
};
RecoveryGradient recovery_log_likelihood_gradient(const RecoveryModel& model,
                                                  const ForwardParameters& parameters,
                                                  double eta_m_pN_s_per_um,
                                                  const RecoveryData& data,
                                                  const RecoveryLikelihoodOptions& options = {},
                                                  double relative_step = 1e-3);

/// The gradient of the log-likelihood (as recovery_log_likelihood_gradient, for the parameters
/// in `differentiate` = {persistence, lmax, kappa}; the others' entries are 0) and its
/// Gauss-Newton information in (eta_m, persistence, lmax, kappa) (natural units: pN s/um, nm,
/// nm, J), for the gradient sampler. Per cell, with the residuals e_i = (lambda_model(t_i) -
/// lambda_i)/sigma at the nuisances' conditional mode, J_t their derivatives in the parameters
/// (eta_m analytic through the rescaling, du_i/d eta_m = -g'(t_i s) t_i s/eta_m; the others by
/// the same central differences of trajectories as the gradient) and J_n in the nuisances
/// (lambda_inf, r0), the information is the Schur complement
///   J_t' J_t - J_t' J_n (J_n' J_n)^-1 J_n' J_t,
/// the Gauss-Newton information of the likelihood with the nuisances marginalised (or
/// profiled; the Laplace determinant's dependence on the parameters, a term of order 1 against
/// the residuals' order n, is left out, as Gauss-Newton drops the residuals' curvature).
/// Rows and columns of parameters not differentiated are 0. The 1 + 2 x (differentiated)
/// trajectories run in parallel over the calling thread's OpenMP team, each on one thread, so
/// the result does not depend on the thread count.
struct RecoveryGradientInformation {
  RecoveryGradient gradient;
  Eigen::Matrix4d information = Eigen::Matrix4d::Zero();
  int trajectories = 0;  ///< release-scene simulations made
};
RecoveryGradientInformation recovery_gradient_and_information(
    const RecoveryModel& model, const ForwardParameters& parameters, double eta_m_pN_s_per_um,
    const RecoveryData& data, const RecoveryLikelihoodOptions& options,
    const std::array<bool, 3>& differentiate, double relative_step = 1e-3);

// ---------------------------------------------------------------------------------------------
// Cells with their own viscosity

/// Gauss-Hermite nodes per cell of the between-cell layer. The quadrature is adaptive (centred
/// and scaled at the integrand's mode): 20 nodes agree with 40 to 7e-5 in log L on the four
/// Hochmuth cells and synthetic ones, s from 0.01 to 1 (tests/calibrate/test_recovery_spread.cpp).
/// That floor is the integrand's smoothness, not the node count (10 to 80 nodes all differ from
/// 160 by 1e-6 to 1e-5): RecoveryCurve::at is C1, so the quadrature converges algebraically.
inline constexpr int kRecoverySpreadNodes = 20;

/// One cell of the between-cell layer.
struct RecoverySpreadCell {
  int id = 0;
  double log_term = 0;  ///< log int L_c(eta_m e^{s eps}) phi(eps) d eps; -inf: no node fitted
  /// Its partial derivatives in eta_m (per pN s/um) and s at the quadrature's nodes.
  double d_eta_per_pN_s_per_um = 0, d_spread = 0;
  /// The mode of the integrand: the cell's own viscosity given eta_m, s and its readings.
  double eta_mode_pN_s_per_um = 0;
  double log_eta_sd = 0;  ///< the integrand's width in log eta_c at the mode (1/sqrt(-f''))
};

struct RecoverySpreadLikelihood {
  double log_likelihood = 0;             ///< sum of the cells' terms; -inf when a cell's term is
  double dlog_deta_per_pN_s_per_um = 0;  ///< d log_likelihood / d eta_m (pN s/um)^-1
  double dlog_dspread = 0;               ///< d log_likelihood / d s
  std::vector<RecoverySpreadCell> cells;
};

/// The likelihood of `data` with each cell at its own viscosity eta_m exp(s eps), eps ~ N(0,1):
/// eta_m (pN s/um, > 0), spread s (the sd of log eta over cells, finite; its sign does not
/// matter; s = 0 gives evaluate_recovery_likelihood's value with d/ds = 0), `nodes` Gauss-
/// Hermite nodes per cell (1 to 200) placed at the mode of the cell's integrand in log eta_c
/// (Newton on its analytic derivative, the curvature by central differences of that
/// derivative) with the width 1/sqrt(-f'') there. The derivatives are those of the quadrature
/// sum with its nodes held fixed in eps (d/d eta_m = sum_k p_k D_k eta_k/eta_m, d/ds =
/// sum_k p_k D_k eta_k eps_k, p_k the nodes' shares of the sum, D_k = d log L_c/d eta at eta_k,
/// analytic through the rescaling); they differ from the derivative of the re-centred sum by
/// its quadrature error only. Throws rbc::InvalidParameter for invalid arguments.
RecoverySpreadLikelihood evaluate_recovery_spread_likelihood(
    const RecoveryCurve& curve, double eta_m_pN_s_per_um, double spread, const RecoveryData& data,
    const RecoveryLikelihoodOptions& options = {}, int nodes = kRecoverySpreadNodes);
/// evaluate_recovery_spread_likelihood(...).log_likelihood.
double recovery_spread_log_likelihood(const RecoveryCurve& curve, double eta_m_pN_s_per_um,
                                      double spread, const RecoveryData& data,
                                      const RecoveryLikelihoodOptions& options = {},
                                      int nodes = kRecoverySpreadNodes);

/// The gradient and information of the between-cell likelihood, as
/// recovery_gradient_and_information: log L and d/d eta_m, d/ds from
/// evaluate_recovery_spread_likelihood on the centre trajectory; d/dp, d/dLmax, d/dkappa by
/// central differences of the same trajectories (every node of every cell read on the lo and
/// hi curves). The information in (eta_m, persistence, lmax, kappa, s) is the expected (Fisher)
/// information of a Gaussian approximation of the hierarchy, per cell: its likelihood as a
/// Gaussian in (log eta_c, p, Lmax, kappa) with precision I_c, the Gauss-Newton information
/// of recovery_gradient_and_information at the cell's mode eta_c (log eta_c's row and column
/// times eta_c), and log eta_c ~ N(log eta_m, s^2). The cell's estimate then has covariance
/// Sigma = I_c^-1 + s^2 e e' (e the log eta direction), whose Fisher information is
///   Sigma^-1 = I_c - s^2 I_c e e' I_c / (1 + s^2 e' I_c e)   for (log eta_m, p, Lmax, kappa),
///   1/2 tr(Sigma^-1 dSigma/ds)^2 = 2 s^2 (I_ee / (1 + s^2 I_ee))^2   for s,
/// uncoupled (a Gaussian's mean and variance parameters), log eta_m's row and column divided by
/// eta_m. Both blocks are positive semi-definite; at s = 0 the first is the shared-eta_m
/// information and the second 0 (the likelihood is even in s).
struct RecoverySpreadGradientInformation {
  RecoveryGradient gradient;  ///< d_spread filled
  /// (eta_m, persistence, lmax, kappa, s) in pN s/um, nm, nm, J, 1.
  Eigen::Matrix<double, 5, 5> information = Eigen::Matrix<double, 5, 5>::Zero();
  int trajectories = 0;  ///< release-scene simulations made
};
RecoverySpreadGradientInformation recovery_spread_gradient_and_information(
    const RecoveryModel& model, const ForwardParameters& parameters, double eta_m_pN_s_per_um,
    double spread, const RecoveryData& data, const RecoveryLikelihoodOptions& options,
    const std::array<bool, 3>& differentiate, double relative_step = 1e-3,
    int nodes = kRecoverySpreadNodes);

}  // namespace rbc
