#pragma once
// The Mills et al. 2004 optical-tweezers measurements (data/README.md) and goodness of fit.
#include <istream>
#include <string>
#include <vector>

namespace rbc {

/// One measured point: total force (pN), diameters and half error-bar extents (um).
struct ExperimentPoint {
  double force_pN = 0;
  double axial_um = 0, axial_err_um = 0;
  double transverse_um = 0, transverse_err_um = 0;
};

/// Parses a Mills-format CSV (header force_pN,axial_um,axial_err_um,transverse_um,
/// transverse_err_um; '#' comment lines; blank lines skipped) from a stream. `name` names the
/// source in messages. Throws std::runtime_error naming the source, the line and the
/// offending value for: a missing or unexpected column, a row with the wrong number of
/// values, a non-numeric or non-finite value, a negative force or diameter, a non-positive
/// error bar, forces that do not increase, no data rows. Small and allocation-light, so a
/// fuzz target can call it on arbitrary bytes.
std::vector<ExperimentPoint> parse_experiment(std::istream& in, const std::string& name);

/// Reads a Mills-format CSV file through parse_experiment; a missing file is named too.
std::vector<ExperimentPoint> load_experiment(const std::string& path);

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
