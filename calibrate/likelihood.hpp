// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The likelihood of force-diameter data (MODEL.md section 7): independent Gaussians on the
// axial and transverse diameters,
//   log L = -1/2 sum_k [((D_A(F_k) - D_A,k)/(c s_A,k))^2 + ((D_T(F_k) - D_T,k)/(c s_T,k))^2]
//           - sum_k [log(sqrt(2 pi) c s_A,k) + log(sqrt(2 pi) c s_T,k)],
// c the optional inferred sigma scale (1 when not inferred). The error s of a point is its
// error bar as the data file gives it (half the bar extent; data/README.md), combined in
// quadrature with the extra uncertainty the file declares (`# extra_uncertainty_um:`,
// compare/experiment.hpp) and the one the user adds (`rbc infer --extra-uncertainty`):
//   s = sqrt(err^2 + declared^2 + added^2);
// with neither, s is the file's error bar exactly.
// The 0 pN point is the unstretched cell, one measured diameter for both columns: it enters
// once, as an axial term against the model's D_A(0) (the rest shape is axisymmetric, so
// D_T(0) = D_A(0) up to the mesh).
//
// Hierarchical layer over experiments (optional, `rbc infer --params ...,tau`). Several data
// sets from different cell samples, tweezers and calibrations may sit apart by more than their
// error bars. Each experiment e gets an unknown offset delta_e ~ N(0, tau^2) common to all of
// its D_A points, and another, independent one common to all of its D_T points; tau (um) is
// the between-experiment standard deviation, inferred. Integrating the offsets out analytically,
// each of the two columns of an experiment is a Gaussian with covariance
//   Sigma = diag(s^2) + tau^2 1 1'   (s = c sigma, the points' scaled error bars),
// whose log-density follows in closed form from Sherman-Morrison and the matrix determinant
// lemma (w_i = 1/s_i^2, W = sum w_i, a = sum w_i r_i, r = model - data):
//   r' Sigma^-1 r = sum w_i r_i^2 - tau^2 a^2 / (1 + tau^2 W),
//   log det Sigma = sum log s_i^2 + log(1 + tau^2 W).
// tau = 0 gives the independent likelihood above exactly. The offset stands for what shifts a
// whole curve of one experiment (a sample's mean cell size, the image calibration of a set-up):
// a large tau says the data sets disagree by a common shift, not point by point.
#include <span>
#include <string>
#include <vector>

#include "compare/experiment.hpp"
#include "compare/methods.hpp"

namespace rbc {

/// The data as the likelihood uses them: forces and, per force, the terms that enter.
struct DiameterData {
  std::vector<double> force_pN;
  std::vector<double> axial_um, axial_sigma_um;            ///< sigma: quadrature total (um)
  std::vector<double> transverse_um, transverse_sigma_um;  ///< sigma: quadrature total (um)
  std::vector<char> transverse_used;                       ///< 0 at the 0 pN point
  int size() const { return static_cast<int>(force_pN.size()); }
  /// Number of Gaussian terms (2 per force, 1 at 0 pN).
  int terms() const;
  /// Smallest data error bar (um) as given in the file (before any extra uncertainty).
  double smallest_error_bar_um = 0;
  /// The data set's label (ExperimentFile::label: declared name, else file name); empty when
  /// built from bare points.
  std::string name;
  /// Extra uncertainties (um) in the sigmas: declared by the file and added by the user.
  double declared_extra_uncertainty_um = 0, added_extra_uncertainty_um = 0;
  /// Their quadrature sum, the extra part of every sigma (um).
  double extra_uncertainty_um() const;
};

/// Builds the likelihood's data from measured points (forces increasing, validated by
/// parse_experiment) and one extra uncertainty (um, >= 0, added in quadrature to every error
/// bar; throws std::invalid_argument naming it otherwise). The sigmas are the error bars
/// exactly when it is 0.
DiameterData make_diameter_data(const std::vector<ExperimentPoint>& points,
                                double extra_uncertainty_um);
/// The same for a data file: its declared extra uncertainty and `added_extra_uncertainty_um`
/// (the user's, >= 0) both enter in quadrature; name and both parts are recorded.
DiameterData make_diameter_data(const ExperimentFile& file, double added_extra_uncertainty_um);

/// Refuses data the model of `kind` is not documented to reproduce: throws std::invalid_argument
/// naming the source, the data row (1-based, as parse_experiment counts them) and the force
/// ("experiment file 'f.csv' data row 3: force (continuum model) must be finite and in
/// [0, 400] pN, got 1000 pN") for the first row beyond max_method_force_pN(kind)
/// (calibrate/forward_model.hpp).
void check_data_forces(const std::vector<ExperimentPoint>& points, MethodKind kind,
                       const std::string& source);

/// The data file at `path` (load_experiment_file) as the likelihood of the model of `kind`
/// uses it: read with its declarations, its forces checked by check_data_forces, then
/// make_diameter_data with the user's `added_extra_uncertainty_um` (um, >= 0). Every error
/// names the file; nothing is solved.
DiameterData load_diameter_data(const std::string& path, double added_extra_uncertainty_um,
                                MethodKind kind);

/// Model diameters at the data's forces (um).
struct ModelDiameters {
  std::vector<double> axial_um, transverse_um;
};

/// log L of the model diameters (sizes = data.size()) with every sigma multiplied by
/// sigma_scale (> 0).
double gaussian_log_likelihood(const DiameterData& data, const ModelDiameters& model,
                               double sigma_scale = 1.0);
/// The same with the hierarchical layer: each column (D_A, D_T) of the data set a Gaussian of
/// covariance diag((sigma_scale s)^2) + tau^2 1 1' (tau_um >= 0; 0 gives the function above).
double gaussian_log_likelihood(const DiameterData& data, const ModelDiameters& model,
                               double sigma_scale, double tau_um);

/// log N(r; 0, diag(s^2) + tau^2 1 1') in closed form (Sherman-Morrison, determinant lemma):
/// r the residuals (um), s the standard deviations (um, > 0), tau (um, >= 0).
double shared_offset_log_density(std::span<const double> r_um, std::span<const double> s_um,
                                 double tau_um);

/// One Gaussian block (a column of an experiment) differentiated: residuals r (um), error bars
/// sigma (um, before the scale c), their Jacobian J (rows: points, columns: the parameters'
/// slots, um per unit) in the parameters that move the model. Returns log N(r; 0, Sigma) with
/// Sigma = diag((c sigma)^2) + tau^2 1 1', its gradient in the slots (-J' Sigma^-1 r), in c and
/// in tau, and the Fisher information: J' Sigma^-1 J for the slots and, for the variance
/// parameters c and tau, 1/2 tr(Sigma^-1 dSigma_a Sigma^-1 dSigma_b) (uncoupled from the slots).
struct GaussianBlockGradient {
  double log_density = 0;
  std::vector<double> gradient;  ///< per slot (columns of J)
  double d_scale = 0, d_tau = 0;
  std::vector<double> information;  ///< slots x slots, column-major
  double info_scale = 0, info_tau = 0, info_scale_tau = 0;
};
GaussianBlockGradient gaussian_block_gradient(std::span<const double> r_um,
                                              std::span<const double> sigma_um,
                                              std::span<const double> jacobian_col_major, int slots,
                                              double sigma_scale, double tau_um);

/// The kind of a data file of `rbc infer --data-file`: stretch curves (force_pN, axial_um, ...)
/// or shape-recovery curves (cell, time_s, length_over_width:
/// data/hochmuth1979_recovery_cells.csv).
enum class DataKind { stretch, recovery };
/// "stretch", "recovery".
std::string to_string(DataKind k);
/// The kind from the file's header line (its first line that is neither empty nor a '#'
/// comment): recovery when its columns start with cell,time_s,length_over_width, stretch
/// otherwise (parse_experiment checks that format). Throws std::invalid_argument naming the
/// file when it cannot be read.
DataKind detect_data_kind(const std::string& path);

}  // namespace rbc
