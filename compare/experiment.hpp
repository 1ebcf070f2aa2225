// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The Mills et al. 2004 optical-tweezers measurements (data/README.md) and goodness of fit.
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

/// Reads a Mills-format CSV (force_pN, axial_um, axial_err_um, transverse_um,
/// transverse_err_um); throws std::runtime_error naming the file for a missing file, a
/// wrong header, a malformed or non-finite value, a negative force, a diameter or error bar
/// <= 0 or forces that do not increase from row to row.
std::vector<ExperimentPoint> load_experiment(const std::string& path);
/// The same on a stream (`path` names the source in the messages; fuzz/ feeds it directly).
std::vector<ExperimentPoint> parse_experiment(std::istream& in, const std::string& path);

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
