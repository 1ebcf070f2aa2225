// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The likelihood of force-diameter data (MODEL.md section 7): independent Gaussians on the
// axial and transverse diameters,
//   log L = -1/2 sum_k [((D_A(F_k) - D_A,k)/(c s_A,k))^2 + ((D_T(F_k) - D_T,k)/(c s_T,k))^2]
//           - sum_k [log(sqrt(2 pi) c s_A,k) + log(sqrt(2 pi) c s_T,k)],
// c the optional inferred sigma scale (1 when not inferred). The error s of a point is its
// error bar as the data file gives it (half the bar extent; data/README.md) combined in
// quadrature with the uncertainty of reading the published figure:
//   s = sqrt(err^2 + reading^2).
// The 0 pN point is the unstretched cell, one measured diameter for both columns: it enters
// once, as an axial term against the model's D_A(0) (the rest shape is axisymmetric, so
// D_T(0) = D_A(0) up to the mesh).
#include <string>
#include <vector>

#include "compare/experiment.hpp"
#include "compare/methods.hpp"

namespace rbc {

/// Default uncertainty of reading the Mills figure (um): the two readings in data/ differ by
/// d_k (13 axial and 12 transverse pairs, the 0 pN diameter once); each reading's own error
/// sd_r then follows from var(d) = 2 sd_r^2: sd_r = rms(d)/sqrt2 = 0.565/sqrt2 = 0.399 um.
/// reading_uncertainty_from_readings() recomputes it (a test checks the constant).
inline constexpr double kMillsReadingUncertaintyUm = 0.399;

/// rms over paired rows (same order; 0 pN counted once) of the diameter differences / sqrt2.
/// Throws std::invalid_argument if the readings have different row counts.
double reading_uncertainty_from_readings(const std::vector<ExperimentPoint>& a,
                                         const std::vector<ExperimentPoint>& b);

/// The data as the likelihood uses them: forces and, per force, the terms that enter.
struct DiameterData {
  std::vector<double> force_pN;
  std::vector<double> axial_um, axial_sigma_um;            ///< sigma: quadrature total (um)
  std::vector<double> transverse_um, transverse_sigma_um;  ///< sigma: quadrature total (um)
  std::vector<char> transverse_used;                       ///< 0 at the 0 pN point
  int size() const { return static_cast<int>(force_pN.size()); }
  /// Number of Gaussian terms (2 per force, 1 at 0 pN).
  int terms() const;
  /// Smallest data error bar (um) as given in the file (before the reading uncertainty).
  double smallest_error_bar_um = 0;
};

/// Builds the likelihood's data from measured points (forces increasing, validated by
/// parse_experiment) and the reading uncertainty (um, >= 0; throws std::invalid_argument
/// naming it otherwise).
DiameterData make_diameter_data(const std::vector<ExperimentPoint>& points,
                                double reading_uncertainty_um);

/// Refuses data the model of `kind` is not documented to reproduce: throws std::invalid_argument
/// naming the source, the data row (1-based, as parse_experiment counts them) and the force
/// ("experiment file 'f.csv' data row 3: force (continuum model) must be finite and in
/// [0, 400] pN, got 1000 pN") for the first row beyond max_method_force_pN(kind)
/// (calibrate/forward_model.hpp).
void check_data_forces(const std::vector<ExperimentPoint>& points, MethodKind kind,
                       const std::string& source);

/// The data file at `path` (load_experiment) as the likelihood of the model of `kind` uses it:
/// read, its forces checked by check_data_forces, then make_diameter_data. Every error names
/// the file; nothing is solved.
DiameterData load_diameter_data(const std::string& path, double reading_uncertainty_um,
                                MethodKind kind);

/// Model diameters at the data's forces (um).
struct ModelDiameters {
  std::vector<double> axial_um, transverse_um;
};

/// log L of the model diameters (sizes = data.size()) with every sigma multiplied by
/// sigma_scale (> 0).
double gaussian_log_likelihood(const DiameterData& data, const ModelDiameters& model,
                               double sigma_scale = 1.0);

}  // namespace rbc
