// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Hamiltonian (hybrid) Monte Carlo with a fixed preconditioning mass matrix: the transition
// that discrete/hmc_sampler.hpp applies to the whole network, written for any smooth target so
// that its law can be checked on systems whose distribution is known in closed form.
//
// Target and Hamiltonian. pi(x) ~ exp(-U(x)) with U = beta F dimensionless (beta = 1/(kB T)).
// Momenta p ~ N(0, M) with M symmetric positive definite; H(x, p) = U(x) + p' M^-1 p / 2. One
// transition (Duane, Kennedy, Pendleton and Roweth 1987; Neal, "MCMC using Hamiltonian
// dynamics", Handbook of MCMC 2011, section 5.2):
//   1. draw p ~ N(0, M) (MassMatrix::draw);
//   2. n leapfrog steps of size h:  p -= h/2 grad U;  x += h M^-1 p;  p -= h/2 grad U;
//   3. accept (x', p') with probability min(1, exp(H(x, p) - H(x', p'))), else keep x.
// The leapfrog map is reversible and volume-preserving for any fixed M, so the chain leaves pi
// invariant exactly, whatever M is, provided the draw in step 1 and the kinetic energy in step 3
// use the SAME M (MassMatrix guarantees both from one factor). A state where U is not finite
// (outside the model's domain: a link past Lmax, a collapsed face) ends the trajectory and is
// rejected, which keeps detailed balance (the reverse trajectory would cross the same state).
//
// Time is dimensionless: with M = beta K and K close to the Hessian of F, the normal modes of
// the harmonic approximation all have angular frequency ~1, so a trajectory of duration pi/2
// takes each mode to an independent state. The number of steps is drawn per transition,
// n = round(T / h) times a factor uniform in [1 - jitter, 1 + jitter] (at least 1), which avoids
// the periodic trajectories of a fixed length (Mackenzie 1989). The step size h is adapted during
// the first adapt_transitions transitions (log h += gain max(1/(1 + k/10), 0.1) (a - target),
// a the acceptance probability of transition k: a fast start, then a floor that keeps following
// the acceptance once the chain has left its start for the thermal states) and then frozen;
// adaptation breaks detailed balance, so those samples are flagged and not used for means.
#include <gsl/gsl_rng.h>

#include <Eigen/Core>
#include <functional>
#include <string>

namespace rbc {

/// The target: U(x) (dimensionless; +infinity outside the domain) and its gradient (written
/// when U is finite).
using HmcPotential = std::function<double(const Eigen::VectorXd& x, Eigen::VectorXd& grad)>;

/// A Gaussian momentum law N(0, M) and the matching M^-1 (dimensionless time: p and M^-1 p
/// carry the units that make p' M^-1 p dimensionless).
class MassMatrix {
 public:
  virtual ~MassMatrix() = default;
  /// A draw of N(0, M) from `rng` (standard normals by gsl_ran_gaussian_ziggurat only).
  virtual Eigen::VectorXd draw(gsl_rng* rng) const = 0;
  /// M^-1 p.
  virtual Eigen::VectorXd inverse_times(const Eigen::VectorXd& p) const = 0;
  /// Linear solves with the underlying factor made per inverse_times() / draw() call
  /// (for the cost accounting of the benchmarks).
  virtual int solves_per_inverse() const { return 1; }
  virtual int solves_per_draw() const { return 1; }
};

/// M = L L' given as a dense matrix (small systems and tests).
class DenseMassMatrix final : public MassMatrix {
 public:
  /// m symmetric positive definite; std::invalid_argument otherwise.
  explicit DenseMassMatrix(const Eigen::MatrixXd& m);
  Eigen::VectorXd draw(gsl_rng* rng) const override;
  Eigen::VectorXd inverse_times(const Eigen::VectorXd& p) const override;

 private:
  Eigen::MatrixXd l_;  ///< lower Cholesky factor of M
};

/// Where the network mass matrix (discrete/hmc_sampler.hpp) is built.
enum class HmcMassReference {
  /// At the chain's start, the zero-temperature equilibrium, for the whole run.
  equilibrium,
  /// At the start during the adaptive phase; at its end rebuilt once at the mean of the chain's
  /// positions over the second half of the adaptive phase, then fixed.
  thermal,
};
std::string to_string(HmcMassReference r);
/// "equilibrium" or "thermal"; std::invalid_argument otherwise.
HmcMassReference hmc_mass_reference_from_string(const std::string& s);

/// How the network sampler (discrete/hmc_sampler.hpp) holds the cell's area and volume.
enum class HmcAreaVolume {
  /// The penalties of the Metropolis sampler's law (McRunSetup::penalty_scale), integrated by
  /// the leapfrog like every other term.
  penalty,
  /// Exact constraints A = A0, V = V0 held by RATTLE (discrete/hmc_constrained.hpp): the law of
  /// infinitely stiff penalties.
  exact,
};
std::string to_string(HmcAreaVolume a);
/// "penalty" or "exact"; std::invalid_argument otherwise.
HmcAreaVolume hmc_area_volume_from_string(const std::string& s);

struct HmcOptions {
  /// Initial leapfrog step h (dimensionless time), in (0, 4]: the steps the adaptation settles
  /// on for the cell at 300 K are 0.07 to 0.15 from N = 250 to 8,000.
  double step = 0.1;
  /// Trajectory duration T (dimensionless time) before the jitter; pi/2 decorrelates every
  /// mode of a harmonic target whose Hessian is beta^-1 M.
  double trajectory_time = 1.5707963267948966;
  double jitter = 0.2;              ///< relative jitter of the step count, in [0, 1)
  int adapt_transitions = 0;        ///< transitions with adaptive step, then frozen
  double target_acceptance = 0.65;  ///< adaptation target, in (0, 1)
  double adapt_gain = 0.5;          ///< log-step change per unit acceptance error, in [0, 10]
  int max_steps = 1000;             ///< cap on leapfrog steps per transition (>= 1)
  /// Network mass matrix (discrete/hmc_sampler.hpp): the exact Hessian at the reference where it
  /// factorises (false), or always the element-wise projected one (true).
  bool projected_mass = false;
  /// Network mass matrix: diagonal shift of K0 as a fraction of its mean diagonal, in
  /// [1e-8, 1]: the floor of the mass of modes the Hessian makes soft.
  double mass_shift_fraction = 1e-4;
  /// Network mass matrix: built at the zero-temperature equilibrium (default) or rebuilt once at
  /// the end of the adaptive phase at the thermal mean positions (needs McOptions::adapt_sweeps
  /// >= 2, checked by McOptions::validate()).
  HmcMassReference mass_reference = HmcMassReference::equilibrium;
  /// Network sampler: the area and volume as penalties (the Metropolis sampler's law) or as
  /// exact constraints.
  HmcAreaVolume area_volume = HmcAreaVolume::exact;
  /// Throws rbc::InvalidParameter naming the value.
  void validate() const;
};

/// The chain's state between transitions: position, U and grad U there.
struct HmcState {
  Eigen::VectorXd x;
  double potential = 0;  ///< U(x)
  Eigen::VectorXd gradient;
};

/// What one transition did.
struct HmcTransition {
  bool accepted = false;
  bool diverged = false;    ///< left the domain (U not finite) or |dH| > 1000
  double energy_error = 0;  ///< H(x', p') - H(x, p) (NaN when diverged)
  double acceptance_probability = 0;
  int steps = 0;              ///< leapfrog steps taken
  long long evaluations = 0;  ///< potential + gradient evaluations
  long long solves = 0;       ///< mass-matrix solves (inverse_times and draw)
};

/// Evaluates the state at x (U and grad U).
HmcState hmc_state(const HmcPotential& potential, const Eigen::VectorXd& x);

/// One HMC transition with `steps` leapfrog steps of size `step` from `state` (updated in place
/// when accepted). Draws the momentum and the acceptance uniform from rng.
HmcTransition hmc_transition(const HmcPotential& potential, const MassMatrix& mass, HmcState& state,
                             double step, int steps, gsl_rng* rng);

/// The Metropolis test of a transition from H = h0 to h1 (+infinity when the trajectory left the
/// domain): fills t.energy_error, t.diverged (not finite, or |dH| > 1000) and
/// t.acceptance_probability, and sets t.accepted from one uniform of rng, drawn on every
/// transition (also divergent ones) so the stream's position never depends on the outcome.
void hmc_metropolis_test(double h0, double h1, gsl_rng* rng, HmcTransition& t);

/// The step count of a transition: round(T/h (1 + jitter (2u - 1))) clamped to [1, max_steps],
/// u uniform from rng.
int hmc_step_count(const HmcOptions& options, double step, gsl_rng* rng);

/// The adapted step after a transition with acceptance probability a, the k-th (0-based) of the
/// adaptive phase.
double hmc_adapted_step(const HmcOptions& options, double step, double acceptance_probability,
                        long long k);

}  // namespace rbc
