// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Optical-tweezers stretch data files (data/README.md; docs/guide/infer.md, "Data files": the
// format and the declarations in a file's header) and the goodness of fit of a model curve against
// them.
#include <iosfwd>
#include <string>
#include <vector>

namespace rbc {

/// One measured point: total force (pN), diameters and half error-bar extents (um).
struct ExperimentPoint {
  double force_pN = 0;
  double axial_um = 0, axial_err_um = 0;
  double transverse_um = 0, transverse_err_um = 0;
};

/// Reads a stretch-data CSV (force_pN, axial_um, axial_err_um, transverse_um,
/// transverse_err_um); throws std::runtime_error naming the file for a missing file, a
/// wrong header, a malformed or non-finite value, a negative force, a diameter or error bar
/// <= 0 or forces that do not increase from row to row.
std::vector<ExperimentPoint> load_experiment(const std::string& path);
/// The same on a stream (`path` names the source in the messages; fuzz/ feeds it directly).
/// Both check the file's declarations (ExperimentFile) too.
std::vector<ExperimentPoint> parse_experiment(std::istream& in, const std::string& path);

/// A stretch-data file with what its header declares. A declaration is a comment line
/// `# key: value` with one of the keys
///   name                  the data set's name as plots and summaries show it
///   extra_uncertainty_um  an uncertainty (um, finite, >= 0) added in quadrature to every error
///                         bar of the file by the likelihood (calibrate/likelihood.hpp)
/// Any other comment is free text, except that a comment `# word: ...` whose word contains
/// "uncertainty" must be exactly extra_uncertainty_um (a misspelt declaration is refused, not
/// ignored). A key declared twice, an empty name or a bad value is refused naming the file.
struct ExperimentFile {
  std::string path;
  std::string name;                 ///< declared name; empty: none declared
  double extra_uncertainty_um = 0;  ///< declared extra uncertainty (um); 0: none declared
  std::vector<ExperimentPoint> points;
  /// The declared name, else the file name without its directory.
  std::string label() const;
};

/// Reads a stretch-data CSV and its declarations; throws std::runtime_error naming the file
/// for every defect load_experiment refuses and for a bad declaration.
ExperimentFile load_experiment_file(const std::string& path);
/// The same on a stream (`path` names the source in the messages and gives the label).
ExperimentFile parse_experiment_file(std::istream& in, const std::string& path);

/// A data set's label as plot text in the house style (compare/plot.hpp): underscores and
/// gnuplot's other special characters escaped, a single quote shown as a typographic one.
std::string experiment_plot_label(const std::string& label);

/// Directory holding the project's data files: $RBC_DATA_DIR if set, else the source tree's data/.
std::string default_data_directory();

/// A model curve sampled at the experimental forces.
struct CurveSample {
  double force_pN = 0, axial_um = 0, transverse_um = 0;
};

/// RMS error (um) of D_A and D_T and how many points fall inside their error bars.
struct FitQuality {
  double axial_rms_um = 0, transverse_rms_um = 0;
  int axial_inside = 0, transverse_inside = 0, points = 0;
};

/// Compares a model curve with the experiment; the model is interpolated linearly in force
/// (it must cover the experimental force range; throws std::invalid_argument otherwise).
FitQuality fit_quality(const std::vector<ExperimentPoint>& experiment,
                       const std::vector<CurveSample>& model);

}  // namespace rbc
