// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Disordered periodic spectrin networks: a jittered triangular lattice on a square torus,
// triangulated by periodic Delaunay (homogenise/periodic_delaunay.hpp), every link and face
// stress-free at its own reference length and area (MODEL.md section 2), and the affine
// (Cauchy-Born) and relaxed moduli of that network from the cell problem
// (homogenise/periodic_network.hpp).
//
// Note (a consequence of MODEL.md section 2 we measure, not a choice): with per-element
// references every link still carries the tension sqrt3 V'(1) L_e at rest, so a
// disordered network is not in equilibrium at its reference and carries the isotropic
// prestress tr(P)/2 = sqrt3 V'(1) Phi / A, Phi = 1/2 sum L_e^2 - sqrt3 A >= 0; relaxation
// lowers it but a non-equilateral network keeps part of it. The moduli are then tangent
// moduli: 4 mu and 4 K are d2Psi/ds2 along F = I + s D (moduli_from_tangent).
#include <vector>

#include "core/progress.hpp"
#include "homogenise/periodic_network.hpp"

namespace rbc {

/// Point set: columns i = 0..n-1, rows j = 0..m-1 (m the even number nearest 2n/sqrt3, so
/// the lattice is nearly equilateral on the square of side n a), row j shifted by a/2 when
/// odd; each point displaced uniformly in a disc of radius disorder * jitter_fraction * a.
struct DisorderOptions {
  int cells = 8;                 ///< n, lattice columns across the square (>= 4)
  double disorder = 0.5;         ///< X in [0, 1]
  double spacing_um = 0.075;     ///< lattice spacing a (um); moduli do not depend on it
  double jitter_fraction = 0.4;  ///< largest displacement at X = 1, in units of a (< 0.5)
  /// Throws rbc::InvalidParameter naming the value: cells in [4, 200], X in [0, 1], spacing in
  /// (0, 1] um, jitter in [0, 0.5), all finite.
  void validate() const;
};

/// The network for one seed (validated options; deterministic in the seed).
PeriodicNetwork make_disordered_network(const DisorderOptions& o, unsigned seed);

/// Rows m used for `cells` n, and the relative deviation of the row spacing from the
/// equilateral sqrt3/2 a (the anisotropy of the X = 0 network).
int disordered_rows(int cells);
double disordered_row_distortion(int cells);

/// Per-seed measurements (moduli in pN/um).
struct DisorderedSample {
  int vertices = 0;
  double degree6_fraction = 0.0;
  double phi_over_area = 0.0;        ///< Phi/A at the reference (0 only if equilateral)
  LinearModuli affine;               ///< Cauchy-Born: affine deformation of the reference
  LinearModuli relaxed;              ///< relaxed internal positions, Schur complement tangent
  LinearModuli affine_at_relaxed;    ///< affine tangent at the relaxed state (>= relaxed)
  double prestress_pN_per_um = 0.0;  ///< isotropic tension tr(P)/2 of the relaxed network
  double psi_reference_pN_per_um = 0.0, psi_relaxed_pN_per_um = 0.0;
  CellRelaxResult relax;
};
DisorderedSample analyse_disordered(const DisorderOptions& o, const NetworkMaterial& m,
                                    unsigned seed, const RelaxOptions& relax = {});

struct MeanStd {
  double mean = 0.0, std = 0.0;  ///< sample standard deviation (0 for a single sample)
};
MeanStd mean_std(const std::vector<double>& values);

/// Seeds first_seed .. first_seed + seeds - 1; progress one line per seed.
std::vector<DisorderedSample> disordered_study(const DisorderOptions& o, const NetworkMaterial& m,
                                               int seeds, unsigned first_seed = 1,
                                               const RelaxOptions& relax = {},
                                               const ProgressSink& progress = {});

}  // namespace rbc
