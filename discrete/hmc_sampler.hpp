// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Hamiltonian Monte Carlo of the whole spectrin network (discrete/hmc_kernel.hpp applied to
// every vertex at once): the collective sampler of `rbc mc --sampler hmc`. It samples
// pi(x) ~ exp(-beta F(x)), F the network's free energy network_energy(), beta = 1/(kB T) at the
// sampling temperature, with the area and volume held exactly (HmcOptions::area_volume exact,
// the default: the limit of infinitely stiff penalties) or by the penalties times
// LoadState::stiffness_scale with the multipliers held fixed (penalty: exactly the law of the
// Metropolis sampler, discrete/mc_sampler.hpp).
//
// Mass matrix (pN/um, times beta): built at the chain's reference positions (the
// zero-temperature equilibrium, or the thermal mean, see "Reference" below), and never changed
// during the production transitions, so they are exact HMC:
//   M = beta (K0 + U C U'),
//   K0 = the network Hessian (discrete/network_hessian.hpp) at the reference: the exact one
//        plus a shift of HmcOptions::mass_shift_fraction times its mean diagonal when that
//        factorises (and HmcOptions::projected_mass is off), else the
//        element-wise projected one (semidefinite, same shift);
//   U = [dA/dx, dV/dx, t_x, t_y, t_z, r_x (, r_y, r_z)],
//   C = diag(s k_A, s k_V, c, c, c, 1e4 c (, 1e4 c, 1e4 c)): the rank-two part of the area and
//        volume penalties, which the sparse Hessian leaves out (with them the step would be
//        capped by the stiffest, global, modes), and the zero modes of F: the unit translations
//        t and the unit rotations r about the axes rigid_rotation_axes() names (the stretch axis
//        x under a bead force; all three axes at zero force), at the reference. The translations
//        get the mass c = the mean diagonal of K0, so that no momentum along them turns into a
//        large velocity; the rotations 1e4 c, so that the cell keeps its orientation to the
//        fixed mass matrix (a turned cell's stiff directions leave the matrix's).
// Reference (HmcOptions::mass_reference). equilibrium: M is built at the start (the
// zero-temperature equilibrium) for the whole run. thermal: M is built at the start, the chain's
// positions after each transition k of the second half of the adaptive phase
// (k = floor(a/2) .. a-1, a = McOptions::adapt_sweeps) are summed, and after transition a-1 M is
// rebuilt once, by the same construction, at their mean x_bar (the Hessian and the area, volume
// and rotation columns at x_bar). M is fixed from transition a on, so the production chain (the
// samples McRun::summarise() uses) is exact HMC with that M: the law is unchanged, like the step
// adaptation this is a choice of the adaptive phase. The zero-temperature Hessian is stiffer
// than the thermal shape's along slow collective directions (D_A at 300 K:
// docs/validation/monte-carlo.md, "Collective moves"). When the energy at x_bar is not finite
// or neither Hessian factorises there, M stays the start's (HmcMassInfo::thermal false).
//
// M^-1 is applied by Sherman-Morrison-Woodbury on one CHOLMOD factorisation of K0 (double
// precision: the kinetic energy, the drifts and the momentum draws all use this one factor):
//   M^-1 p = (K0^-1 p - W S^-1 U' K0^-1 p) / beta,  W = K0^-1 U,  S = C^-1 + U' W;
// a momentum is p = sqrt(beta) (K0 G'^-1 z1 + U C^1/2 z2), K0 = G G', z1, z2 standard normal,
// a draw of N(0, M) (the sum of independent draws of N(0, beta K0) and N(0, beta U C U')).
// Cost per transition: n + 2 solves and n energy + gradient evaluations for n leapfrog steps,
// plus one factor solve for the draw.
//
// Start: a draw of N(start, M^-1), the Gaussian approximation of the target about the start
// positions (HmcSampler::start_near says why not the start itself).
//
// Area and volume (HmcOptions::area_volume). penalty: as above, the Metropolis sampler's law.
// exact: the constraints A = A0, V = V0 held by RATTLE (discrete/hmc_constrained.hpp), F without
// the penalty and multiplier terms (zero on the manifold), M without the dA, dV columns; the law
// is the limit of infinitely stiff penalties. The penalties' gradients turn with the thermal
// shape, away from the fixed M, and cap the leapfrog step (docs/validation/monte-carlo.md,
// "Exact area and volume"); the constraints remove that cap. The start (and a restored state)
// is projected onto the manifold along M^-1 J' (a no-op for a state already on it). energy()
// is F without the Fixman term.
//
// The area, volume and energy reported are those of the last evaluation (network_geometry's
// fixed-order sums): bit-reproducible for any thread count, no running totals, so no drift.
#include <Eigen/Cholesky>
#include <Eigen/SparseCore>
#include <memory>
#include <vector>

#include "core/sparse_cholesky.hpp"
#include "discrete/hmc_constrained.hpp"
#include "discrete/mc_sampler.hpp"

namespace rbc {

/// The axes (0 = x, 1 = y, 2 = z) of the rigid rotations that leave the network's free energy
/// unchanged under `load`: x alone when the beads pull (force != 0), all three at zero force.
std::vector<int> rigid_rotation_axes(const LoadState& load);

/// How the mass matrix was made (recorded with the run).
struct HmcMassInfo {
  bool exact = false;               ///< the exact Hessian (else the projected one)
  double shift_pN_per_um = 0;       ///< diagonal shift added to K0
  double rigid_mass_pN_per_um = 0;  ///< c, the mass of the four zero modes
  double factor_nonzeros = 0;       ///< of the Cholesky factor of K0
  /// Built at the thermal mean positions (HmcMassReference::thermal, after the adaptive phase);
  /// false at the start positions.
  bool thermal = false;
  /// Transitions whose positions were averaged for the thermal reference (0 when not thermal).
  long long reference_transitions = 0;
};

/// M = beta (K0 + U C U') at positions x (see above), with its factor. Prepared state: built
/// once, then read only (draw and inverse_times are not for concurrent calls on one object).
class NetworkMassMatrix final : public MassMatrix {
 public:
  /// Throws std::runtime_error when neither Hessian factorises.
  NetworkMassMatrix(const Network& net, const LoadState& load, const Positions& x,
                    double beta_per_pNum, const HmcOptions& options = {});
  Eigen::VectorXd draw(gsl_rng* rng) const override;
  Eigen::VectorXd inverse_times(const Eigen::VectorXd& p) const override;
  const HmcMassInfo& info() const { return info_; }
  /// K0 (lower triangle, pN/um), U (3N x 6, or 3N x 8 at zero force) and diag C (pN/um):
  /// M = beta (K0 + U C U').
  const Eigen::SparseMatrix<double>& sparse_part() const { return k0_; }
  const Eigen::MatrixXd& low_rank_columns() const { return u_; }
  const Eigen::VectorXd& low_rank_stiffness() const { return c_; }

 private:
  double beta_;
  SparseCholesky factor_;
  Eigen::SparseMatrix<double> k0_;  ///< lower triangle, pN/um
  Eigen::MatrixXd u_, w_;           ///< U (3N x 6 or 8) and K0^-1 U
  Eigen::VectorXd c_;               ///< diag C, pN/um
  Eigen::LDLT<Eigen::MatrixXd> capacitance_;
  HmcMassInfo info_;
};

/// The collective sampler. Owns the prepared state (mass matrix factor, RNG stream); the
/// network must outlive it.
class HmcSampler final : public McChain {
 public:
  /// Starts the chain near `start` (feasible, typically the zero-temperature equilibrium): at a
  /// draw of the mass matrix's Gaussian approximation of the target about it, N(start, M^-1),
  /// so that every mode starts with a thermal amplitude. The mass matrix is built at `start`.
  /// options.algorithm must be hmc and options.temperature_K > 0 (std::invalid_argument).
  HmcSampler(const Network& net, const LoadState& load, const Positions& start,
             const McOptions& options);
  /// As above with the mass matrix built at `mass_reference` (a resumed chain's).
  HmcSampler(const Network& net, const LoadState& load, const Positions& start,
             const Positions& mass_reference, const McOptions& options);
  ~HmcSampler() override;
  HmcSampler(const HmcSampler&) = delete;
  HmcSampler& operator=(const HmcSampler&) = delete;

  McSweepStats sweep() override;
  double energy() const override;
  const Positions& positions() const override { return x_; }
  double step_um() const override { return step_; }
  long long sweeps_done() const override { return sweep_; }
  double area_um2() const override { return area_; }
  double volume_um3() const override { return volume_; }
  const McThreadDecision& thread_decision() const override { return threads_; }
  double max_area_drift_um2() const override { return 0.0; }
  double max_volume_drift_um3() const override { return 0.0; }
  int mobile_vertices() const override;
  int colour_count() const override { return 0; }
  McAlgorithm algorithm() const override { return McAlgorithm::hmc; }
  McChainState state() const override;
  void restore(const McChainState& s) override;

  /// The last transition (energy error, steps, acceptance probability, evaluations, solves).
  const HmcTransition& last_transition() const { return last_; }
  /// Totals over all transitions of this object: energy + gradient evaluations, mass-matrix
  /// solves (the factor's: one per M^-1 application and one per momentum draw).
  long long evaluations() const { return evaluations_; }
  /// Exact constraints: RATTLE steps whose position solve failed, or whose reverse check did not
  /// return to the start (each ended its trajectory, rejected).
  long long failed_solves() const { return failed_solves_; }
  long long failed_reverse_checks() const { return failed_reverse_checks_; }
  long long solves() const { return solves_; }
  /// How the mass matrix in use was made (after a restore past the thermal rebuild: thermal as
  /// the options say, the state holding the positions it was built at).
  const HmcMassInfo& mass_info() const { return mass_info_; }
  double beta_per_pNum() const { return beta_; }

 private:
  void set_state(const Positions& x);
  /// The chain's first state: a draw of N(centre, M^-1) (see the definition for why).
  void start_near(const Positions& centre);
  /// First transition (0-based) of the thermal reference's averaging window.
  long long window_start() const { return opt_.adapt_sweeps / 2; }
  /// Thermal reference: adds the positions to the window's sum, and after the last adaptive
  /// transition rebuilds the mass matrix at the mean.
  void accumulate_reference();

  const Network& net_;
  LoadState load_;
  McOptions opt_;
  double beta_ = 0;
  Positions x_, reference_;
  Positions reference_sum_;    ///< thermal reference: sum of positions over the window so far, um
  HmcConstrainedState state_;  ///< fixman 0 with penalties
  LoadState potential_load_;   ///< load_, or without penalties and multipliers (exact constraints)
  std::unique_ptr<HmcConstraints> constraints_;  ///< A = A0, V = V0 (HmcAreaVolume::exact)
  long long failed_solves_ = 0, failed_reverse_checks_ = 0;
  double step_ = 0;
  long long sweep_ = 0;
  double area_ = 0, volume_ = 0;
  long long evaluations_ = 0, solves_ = 0;
  HmcTransition last_;
  McThreadDecision threads_;
  std::unique_ptr<NetworkMassMatrix> mass_;
  HmcMassInfo mass_info_;
  HmcPotential potential_;
  struct RngFree {
    void operator()(gsl_rng* r) const noexcept { gsl_rng_free(r); }
  };
  std::unique_ptr<gsl_rng, RngFree> rng_;
};

}  // namespace rbc
