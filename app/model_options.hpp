// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The model description every sub-command shares: the spectrin links (WLC), the steric term,
// the bending energy and the bead contact, as one CLI11 option group ("Model") with the same
// names, defaults and limits in stretch, relax, mc, dynamics, fig7, tradeoff and infer (its fixed
// parameters). Natural units at the edge (nm, K, J, 1/um); converted once into the libraries'
// parameter structs here.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "app/cli_util.hpp"
#include "core/defaults.hpp"
#include "discrete/network.hpp"

namespace rbc::app {

/// The shared physics in natural units. Defaults: paper Tables 1-2 (core/defaults.hpp).
struct ModelCli {
  double lbar_nm = defaults::kLbar_nm;                 ///< --lbar: spectrin rest link length
  double lmax_nm = defaults::kLmax_nm;                 ///< --lmax: spectrin contour length
  double persistence_nm = defaults::kPersistence_nm;   ///< --persistence: persistence length p
  double temperature_K = defaults::kWlcTemperature_K;  ///< --temperature: of the WLC constants
  double kappa_J = defaults::kKappa_J;                 ///< --kappa: bilayer bending rigidity
  double h0_per_um = 0.0;                              ///< --h0: spontaneous curvature
  double q = 1.0;                                      ///< --q: steric exponent (dimensionless)
  double eta = 0.005;                      ///< --eta: steric regularisation (dimensionless)
  PatchRule contact = PatchRule::by_area;  ///< --contact: how the bead patches are chosen
  double contact_fraction = 0.05;          ///< --contact-fraction: patch area per bead / cell area
  BendingModel bending = BendingModel::juelicher;  ///< --bending (discrete network)
  DihedralMapping dihedral_mapping = DihedralMapping::sphere_matched;  ///< --dihedral-mapping
};

/// Adds the option group "Model" to `cmd`, bound to `m` (which must outlive the parse). A
/// command whose own option takes one of the names (relax's --h0 is a list) lists it in `omit`.
void add_model_options(CLI::App* cmd, ModelCli& m, const std::vector<std::string>& omit = {});

/// The long names of the group's options ("--lbar", ...), e.g. to list which physics a run
/// changed from the defaults.
const std::vector<std::string>& model_option_flags();

/// Library quantity -> option, for naming_options (errors name the option the user typed).
const OptionNames& model_option_names();

/// The network's parameters (WLC, steric, bending, bead contact) from `m`, validated
/// (rbc::InvalidParameter naming the quantity). The bending rigidity must be > 0: a closed cell
/// without bending has no definite shape.
NetworkParameters to_network_parameters(const ModelCli& m);
/// As to_network_parameters, with an invalid value reported by its option: std::invalid_argument
/// "--lmax 50: Lmax (contour length, > Lbar) must be ..." (exit 2).
NetworkParameters checked_network_parameters(const ModelCli& m);

}  // namespace rbc::app
