// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The `rbc moduli` study as a library function (used by the CLI and the Python package):
// closed-form moduli (Sec. 4.3), the paper's explicit formulas, and the numerical cell problem
// on a periodic hexagonal patch (with the Theorem 3 check) or on disordered networks. Moduli in
// pN/um (= uN/m).
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>

#include "core/progress.hpp"
#include "homogenise/periodic_network.hpp"

namespace rbc {

/// Theorem 3 (Hartmann 2008 Sec. 3.4) check: at a finite deformation F the relaxed periodic
/// hexagonal patch is the affine map (no internal displacement), from any non-affine start, and
/// its energy density equals the lattice density Psi(F) (homogenise/lattice_density.hpp).
struct Theorem3Options {
  /// A generic finite deformation (det F > 0): stretch, shear and rotation mixed.
  Eigen::Matrix2d F = (Eigen::Matrix2d() << 1.3, 0.2, -0.1, 0.9).finished();
  /// Start: every vertex displaced by a uniform random vector with components in
  /// [-a Lbar, a Lbar] (dimensionless a).
  double start_amplitude_over_lbar = 0.1;
  unsigned seed = 1;  ///< std::mt19937 seed of the start
  /// Throws rbc::InvalidParameter: F finite with det F > 0, amplitude finite in [0, 0.5].
  void validate() const;
};

struct Theorem3Check {
  CellRelaxResult relax;                  ///< the relaxation from the random start
  double psi_lattice_pN_per_um = 0;       ///< Psi(F) of the lattice (closed form)
  double psi_patch_pN_per_um = 0;         ///< relaxed patch energy / reference area
  double max_displacement_over_lbar = 0;  ///< largest internal displacement / Lbar
  double start_amplitude_over_lbar = 0;
  double psi_relative_difference() const {
    return psi_patch_pN_per_um / psi_lattice_pN_per_um - 1.0;
  }
};

/// Relaxes `patch` (a hexagonal patch of spacing lbar_um) at options.F from the seeded start.
Theorem3Check theorem3_check(const PeriodicNetwork& patch, const NetworkMaterial& material,
                             double lbar_um, const Theorem3Options& options = {});

/// Which network the numerical moduli come from; spelled "hex", "disordered".
enum class ModuliNetwork { hexagonal, disordered };
std::string to_string(ModuliNetwork n);
/// Throws std::invalid_argument ("network 'x' is not one of hex, disordered").
ModuliNetwork moduli_network_from_string(const std::string& s);

struct ModuliStudyOptions {
  ModuliNetwork network = ModuliNetwork::hexagonal;
  int cells = 0;          ///< patch size n (0: 4 for hex, 12 for disordered)
  double disorder = 0.5;  ///< disorder X in [0, 1] (disordered only)
  int seeds = 4;          ///< random networks (disordered only), in [1, 1000]
  Theorem3Options theorem3;
  /// Throws rbc::InvalidParameter: disorder in [0, 1], seeds in [1, 1000], cells in
  /// [0, kMaxHexagonalPatchCells] for hex, in [0, 200] otherwise, theorem3.validate().
  void validate() const;
};

struct ModuliStudy {
  /// The keys of `rbc moduli --json` except the timing "wall_s" (the disordered study's
  /// "wall_per_seed_s" is timing too): network, mu_closed_pN_per_um, K_closed_pN_per_um,
  /// young_closed_pN_per_um, poisson_closed, mu_paper_formula_pN_per_um,
  /// K_paper_formula_pN_per_um, steric_C_pN_per_um, then the numerical keys. Every key names
  /// its unit (moduli and tensions in pN/um = uN/m) or is dimensionless (poisson*, *_fraction,
  /// *_relative_difference, *_over_lbar, counts, flags and names).
  nlohmann::json json;
  bool converged = true;
  /// When !converged: "cell problem did not converge: <status>, residual <r> pN" (hex) or
  /// "relaxation did not converge for every seed, worst residual <r> pN".
  std::string failure;
  double phi_over_area_std = 0;  ///< disordered: sample std of Phi/A (text report only)
};

ModuliStudy run_moduli_study(const WlcParameters& wlc, const StericParameters& steric,
                             const ModuliStudyOptions& options, const ProgressSink& progress = {});

}  // namespace rbc
