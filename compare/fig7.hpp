// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The paper's Fig. 7: axial and transverse diameters against force for the Mills 2004
// measurements, the microscopic (discrete) model and the continuum model orders.
#include <string>
#include <vector>

#include "compare/experiment.hpp"
#include "compare/methods.hpp"

namespace rbc {

struct Fig7Options {
  /// Forces (pN), increasing: the Mills forces, then on to 300 pN where the laws part.
  std::vector<double> forces_pN = {0,     16,    19.5, 30.6,  38,  46.6, 67.6, 87.6,
                                   108.8, 130.0, 151,  172.8, 193, 220,  250,  300};
  std::vector<Method> methods;  ///< default: see default_fig7_methods()
  std::string data_dir;         ///< empty: default_data_directory()
  /// The physics of every method (default: paper Tables 1-2).
  NetworkParameters parameters;
  /// Comment lines every written CSV carries (what produced it: app/run_config.hpp).
  std::vector<std::string> provenance;
};

/// Default methods: the discrete model at N = 2,000 and, when the continuum model is
/// built, continuum orders 2, 3, 4 and full at 4,000 elements.
std::vector<Method> default_fig7_methods();

struct Fig7Result {
  std::vector<ExperimentPoint> experiment, alternative;
  std::vector<MethodRun> runs;
  std::vector<FitQuality> fits;         ///< per run, against `experiment`, up to 193 pN
  std::vector<std::string> provenance;  ///< Fig7Options::provenance, for the written files
};

/// Throws std::invalid_argument if the forces are not strictly increasing or negative.
void check_increasing_forces(const std::vector<double>& forces_pN);

Fig7Result run_fig7(const Fig7Options& options, const ProgressSink& progress);

/// Writes DIR/fig7.png, fig7_fit.csv, fig7_<method>.csv, experiment CSVs and fig7.json.
void write_fig7(const Fig7Result& result, const std::string& dir);

}  // namespace rbc
