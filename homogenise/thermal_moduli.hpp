// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Shear and area moduli of the periodic spectrin network at a sampling temperature T, against the
// zero-temperature (Gamma-limit) moduli of the cell problem (homogenise/periodic_network.hpp;
// MODEL.md section 3, Theorem 3).
//
// The law sampled. The nodes of the periodic planar network (hexagonal or disordered, in-plane as
// the homogenisation is) sit at x_i = F X_i + u_i in the box deformed by the macroscopic F, with
// the energy E(F, u) of the cell problem (patch_energy: WLC links + steric faces, the same
// kernels as discrete/). The chain samples pi(u) ~ exp(-E(F, u) / (kB T)) at the sampling
// temperature T; the WLC constants kB T_wlc / p keep their own temperature (WlcParameters).
//
// Route to the moduli: the free energy under small imposed strains. The free energy density
//   f(F) = -kB T / A0 ln Z(F),  Z(F) = integral exp(-E(F, u) / (kB T)) du,
// with u over a domain that does not depend on F (the centre-of-mass translation, a free mode
// that moves no link, left out: it would add the one-particle term kB T / A0 F^-T, a 1/N size
// effect), has the isothermal first Piola stress as its gradient,
//   P(F) = df/dF = < dE/dF |_u > / A0          (the mean virial stress of the box),
// and its second derivative is the isothermal tangent. mu(T) and K(T) follow from central
// differences of the mean stress along F = I + s D, s = +-eps, D in {diag(1, -1), [[0, 1], [1,
// 0]], I}: D : (P(+eps) - P(-eps)) / (2 eps) = D : T : D, then moduli_from_tangent's
// combinations mu = (T[D1,D1] + T[D2,D2]) / 8, K = T[I,I] / 4. The chains at +eps and -eps use
// the same random numbers (common random numbers: same seed, same step, three uniforms per move
// (two for the trial, one for the acceptance) whatever the outcome), so they stay coupled and
// most of the sampling noise cancels in the difference. Errors: batch means of the per-sweep
// difference series.
// Why not the stress-fluctuation formula (Born term - A0/(kB T) Cov(P) + kinetic term): it is a
// difference of two large terms (the Born term is the affine tangent, well above the relaxed one
// on a disordered network; the fluctuation term removes the non-affine relaxation), and its
// covariance converges slowly (fourth moments of the stress). Even as T -> 0 the fluctuation
// term tends to the finite Schur correction E_Fu E_uu^-1 E_uF / A0, estimated from samples with
// a relative noise that does not fall with T. The mean-stress difference under common random
// numbers has neither problem: its noise vanishes with T (the T -> 0 limit is the cell
// problem's tangent to the truncation), it reuses patch_energy's stress unchanged, and its only
// bias, the O(eps^2) truncation, is measured at T = 0 by the same central difference
// (zero_temperature_cd).
//
// Sampler: local Metropolis, one node per move (uniform trial in a square of half-width `step`),
// nodes visited in order, the step adapted towards 40 % acceptance in a warm-up chain at F = I
// and then frozen and shared by every chain. Adequate for cells of ~100-2,000 nodes: the cell is
// flat and in-plane only (no bending modes), so its slowest mode, the longest in-plane phonon
// of wavelength n Lbar, relaxes diffusively in ~n^2 sweeps (n = 10-45 cells: 10^2 to 2 10^3
// sweeps), and the measured quantity, the cell stress, is a sum of local terms that decorrelates
// faster still. The chains of one run (six: three directions, two signs) run in parallel, one
// RNG stream each (GSL mt19937 seeded from the seed and the direction): results depend on the
// seed only, never on the thread count. discrete/hmc_kernel.hpp's Hamiltonian transition would
// fit this target too; at these sizes local moves suffice (about 0.3 us per node move: a
// 256-node row of docs/validation/thermal_moduli.md in ~20 CPU s) and need no gradient or mass
// matrix.
//
// Low-temperature check (quasi-harmonic, independent of the sampler): to first order in T,
//   f(F) = E_min(F) / A0 + kB T / (2 A0) ln det H_uu(F) + O(T^2)
// (Laplace's method; H_uu the Hessian of E over the internal positions at the relaxed state,
// vertex 0 pinned), so with q_D = d2/ds2 ln det H_uu(I + s D) at s = 0 (second differences of
// the relaxed cells' Hessians, no sampling) mu(T) - mu(0) = kB T / (16 A0) (q_D1 + q_D2) and
// K(T) - K(0) = kB T / (8 A0) q_I, to O(T^2): the quasi-harmonic prediction.
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/progress.hpp"
#include "homogenise/moduli_study.hpp"
#include "homogenise/periodic_network.hpp"

namespace rbc {

/// The link law of the sampled cell.
enum class CellLaw {
  /// The homogenisation's network: WLC links and steric faces (NetworkMaterial).
  network,
  /// Zero-rest-length harmonic springs E_e = k/2 |d_e|^2 on the links, no face term: an energy
  /// quadratic in the node positions, whose free energy's fluctuation part does not depend on F
  /// (a reference material with closed-form thermal moduli equal to its T = 0 ones).
  harmonic,
};

struct ThermalCellMaterial {
  CellLaw law = CellLaw::network;
  NetworkMaterial network;        ///< law == network
  double spring_pN_per_um = 0.0;  ///< law == harmonic: k (pN/um), > 0
};

/// Options of a thermal moduli run.
struct ThermalModuliOptions {
  /// Sampling temperature (K), in [0, kMaxTemperature_K]. 0: no sampling, the zero-temperature
  /// central difference stands in for the thermal moduli (errors 0).
  double temperature_K = 300.0;
  long long sweeps = 20000;  ///< production sweeps per chain (one move per node each)
  long long warmup_sweeps =
      2000;                ///< step adaptation at F = I, then as many burn-in sweeps per chain
  double strain = 0.005;   ///< eps of the central differences, in (0, 0.05]
  int batches = 20;        ///< batch means for the errors, in [4, 1000], <= sweeps
  int blocks = 10;         ///< progress lines (and cancel polls) per run, in [1, 1000]
  unsigned long seed = 1;  ///< seed of the chains' GSL mt19937 streams
  double target_acceptance = 0.4;  ///< of the step adaptation, in (0, 1)
  /// Initial trial half-width (um); 0: 0.01 x the shortest rest link. In [0, 1] um.
  double initial_step_um = 0.0;
  /// Threads of the parallel chains: 0 = OpenMP's default; results never depend on it.
  int threads = 0;
  /// Polled once per block; true stops the run by throwing Cancelled.
  CancelCheck cancel;
  /// Throws rbc::InvalidParameter naming the value (ranges above; warmup_sweeps in [0, 10^9],
  /// sweeps in [batches, 10^9], threads in [0, 1024]).
  void validate() const;
};

/// A value with its statistical error (one standard error).
struct ValueError {
  double value = 0.0, error = 0.0;
};

/// What a thermal moduli run measured. Moduli, stresses and tensions in pN/um (= uN/m).
struct ThermalModuliResult {
  double temperature_K = 0.0;
  int vertices = 0;
  double area_um2 = 0.0;
  double strain = 0.0;
  ValueError mu, K;  ///< isothermal moduli at T
  /// Per direction: D : T : D at T (FlatF order of moduli_from_tangent), D1, D2, I.
  ValueError tangent_d1, tangent_d2, tangent_i;
  /// Isotropic tension tr(P)/2 at F = I, as the mean over the +-eps cells of the I direction
  /// (exact to O(eps^2); zero_temperature_tension_pN_per_um is the same mean at T = 0).
  ValueError tension_pN_per_um;
  /// Mean energy above the relaxed minimum per degree of freedom (2 (N - 1)), over kB T / 2,
  /// averaged over the six chains: 1 for a quadratic energy (equipartition).
  ValueError equipartition_ratio;
  /// Zero temperature: the Gamma-limit moduli (Schur complement tangent of the relaxed cell at
  /// F = I, homogenise_patch; the closed form for the hexagonal lattice by Theorem 3) and the
  /// same central difference of the relaxed stress (what the thermal moduli tend to as T -> 0,
  /// including the O(eps^2) truncation).
  LinearModuli gamma_limit, zero_temperature_cd;
  double zero_temperature_tension_pN_per_um = 0.0;
  /// The quasi-harmonic prediction at T: zero_temperature_cd plus the O(T) shift above (network
  /// law; equal to zero_temperature_cd for the harmonic law).
  LinearModuli quasi_harmonic;
  double acceptance = 0.0;  ///< production acceptance, mean over chains
  double step_um = 0.0;     ///< the frozen trial half-width
  long long sweeps = 0, warmup_sweeps = 0;
  int batches = 0;
  unsigned long seed = 0;
};

/// Samples the six strained cells of `net` with `material` at options.temperature_K and
/// returns the moduli (validated options and material; throws rbc::InvalidParameter on bad
/// ones, std::runtime_error if the zero-temperature relaxation fails).
ThermalModuliResult thermal_moduli(const PeriodicNetwork& net, const ThermalCellMaterial& material,
                                   const ThermalModuliOptions& options,
                                   const ProgressSink& progress = {});

/// The keys of `rbc moduli --sampling-temperature T --json` for one result (besides the run
/// record and the study's network keys): every key names its unit (_pN_per_um = uN/m, _K, _um,
/// _um2) or is dimensionless (ratios, acceptance, counts). *_error_* are one standard error
/// (batch means); mu_gamma_* / K_gamma_* the zero-temperature Gamma-limit moduli;
/// *_relative_shift = thermal / Gamma-limit - 1.
nlohmann::json to_json(const ThermalModuliResult& r);

/// Which cell `rbc moduli --sampling-temperature` samples: the hexagonal n x n patch (default n =
/// 10, at least 3) or the disordered network of seed 1 (cells default 12, disorder X).
struct ThermalStudyOptions {
  ModuliNetwork network = ModuliNetwork::hexagonal;
  int cells = 0;  ///< 0: 10 for hex, 12 for disordered
  double disorder = 0.5;
  ThermalModuliOptions sampling;
  /// Throws rbc::InvalidParameter: cells 0 or in [3, kMaxHexagonalPatchCells] (hex), 0 or in [4,
  /// 200] (disordered), disorder in [0, 1], sampling.validate().
  void validate() const;
};

/// Builds the cell, samples it (thermal_moduli) and returns to_json of the result with the
/// network keys (network, cells, vertices, disorder), the closed forms (mu_closed_pN_per_um,
/// K_closed_pN_per_um) and the WLC temperature (wlc_temperature_K).
nlohmann::json thermal_moduli_study(const WlcParameters& wlc, const StericParameters& steric,
                                    const ThermalStudyOptions& options,
                                    const ProgressSink& progress = {});

/// One chain at fixed F (exposed for tests): the per-sweep first Piola stress of the box (pN/um,
/// FlatF order) and energy (pN um) over `sweeps` sweeps with step `step_um` frozen, from U0.
struct ThermalChainSeries {
  std::vector<Eigen::Vector4d> stress;
  std::vector<double> energy_pNum;
  double acceptance = 0.0;
  Eigen::Matrix2Xd U;  ///< final internal displacements
};
ThermalChainSeries sample_cell(const PeriodicNetwork& net, const ThermalCellMaterial& material,
                               const Eigen::Matrix2d& F, const Eigen::Matrix2Xd& U0,
                               double temperature_K, double step_um, long long sweeps,
                               unsigned long seed);

/// Energy of the cell under `material` (pN um; +infinity outside the domain), and its first
/// Piola stress dE/dF / A0 (pN/um) when `stress` is non-null and the energy is finite.
double thermal_cell_energy(const PeriodicNetwork& net, const ThermalCellMaterial& material,
                           const Eigen::Matrix2d& F, const Eigen::Matrix2Xd& U,
                           Eigen::Matrix2d* stress = nullptr);

}  // namespace rbc
