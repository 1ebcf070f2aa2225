// SPDX-License-Identifier: GPL-3.0-or-later
// The shared model option group (app/model_options.hpp).
#include "app/model_options.hpp"

#include <algorithm>

#include "core/units.hpp"
#include "core/validation.hpp"
#include "discrete/bending_energy.hpp"
#include "discrete/tweezers.hpp"

namespace rbc::app {

void add_model_options(CLI::App* cmd, ModelCli& m, const std::vector<std::string>& omit) {
  CLI::Option_group* g =
      cmd->add_option_group("Model", "the physics every command shares (paper Tables 1-2)");
  g->add_option("--lbar", m.lbar_nm, "spectrin rest link length (nm), in (0, 10000]")
      ->capture_default_str();
  g->add_option("--lmax", m.lmax_nm, "spectrin contour length Lmax (nm), in (Lbar, 10000]")
      ->capture_default_str();
  g->add_option("--persistence", m.persistence_nm, "persistence length (nm), in (0, 10000]")
      ->capture_default_str();
  g->add_option("--temperature", m.temperature_K,
                "temperature of the spectrin WLC constants k_B T/p (K), in (0, 1000]")
      ->capture_default_str();
  g->add_option("--kappa", m.kappa_J, "bending rigidity (J), in (0, 1e-16]")->capture_default_str();
  if (std::find(omit.begin(), omit.end(), "--h0") == omit.end())
    g->add_option("--h0", m.h0_per_um, "spontaneous curvature H0 (1/um), in [-100, 100]")
        ->capture_default_str();
  g->add_option("--q", m.q, "steric exponent q, in (0, 10]")->capture_default_str();
  g->add_option("--eta", m.eta, "steric regularisation eta, in (0, 1]")->capture_default_str();
  g->add_option("--contact", m.contact, "bead contact rule: area | vertices")
      ->transform(enum_choice<PatchRule>(
          {{"area", PatchRule::by_area}, {"vertices", PatchRule::by_vertex_count}}))
      ->type_name("TEXT")
      ->default_str("area");
  g->add_option("--contact-fraction", m.contact_fraction,
                "contact patch area per bead over the cell's area, in (0, 0.5)")
      ->capture_default_str();
  g->add_option("--bending", m.bending, "network bending energy: juelicher | dihedral")
      ->transform(enum_choice<BendingModel>(
          {{"juelicher", BendingModel::juelicher}, {"dihedral", BendingModel::dihedral}}))
      ->type_name("TEXT")
      ->default_str("juelicher");
  g->add_option("--dihedral-mapping", m.dihedral_mapping,
                "dihedral k_b(kappa): sphere (2 sqrt3 kappa) | li (2 kappa/sqrt3)")
      ->transform(enum_choice<DihedralMapping>(
          {{"sphere", DihedralMapping::sphere_matched}, {"li", DihedralMapping::li_et_al}}))
      ->type_name("TEXT")
      ->default_str("sphere");
}

const std::vector<std::string>& model_option_flags() {
  static const std::vector<std::string> flags = {
      "--lbar", "--lmax", "--persistence", "--temperature",      "--kappa",   "--h0",
      "--q",    "--eta",  "--contact",     "--contact-fraction", "--bending", "--dihedral-mapping"};
  return flags;
}

const OptionNames& model_option_names() {
  static const OptionNames names = {
      {"Lbar (rest length)", "--lbar"},
      {"Lmax (contour length, > Lbar)", "--lmax"},
      {"persistence length", "--persistence"},
      {"temperature", "--temperature"},
      {"bending rigidity kappa", "--kappa"},
      {"spontaneous curvature H0", "--h0"},
      {"steric exponent q", "--q"},
      {"steric regularisation eta", "--eta"},
      {"bead contact fraction", "--contact-fraction"},
  };
  return names;
}

NetworkParameters to_network_parameters(const ModelCli& m) {
  NetworkParameters p;
  p.wlc.lbar_um = units::nm_to_um(m.lbar_nm);
  p.wlc.lmax_um = units::nm_to_um(m.lmax_nm);
  p.wlc.persistence_um = units::nm_to_um(m.persistence_nm);
  p.wlc.temperature_K = m.temperature_K;
  p.bending.kappa_pNum = units::joule_to_pNum(m.kappa_J);
  p.bending.h0_per_um = m.h0_per_um;
  p.bending_model = m.bending;
  p.dihedral_mapping = m.dihedral_mapping;
  p.steric.q = m.q;
  p.steric.eta = m.eta;
  p.tweezers.rule = m.contact;
  p.tweezers.contact_fraction = m.contact_fraction;
  p.validate();
  // Without bending the closed network has no definite shape to stretch (the library allows
  // kappa = 0 for flat test patches; a cell needs kappa > 0).
  require_finite_in_range("bending rigidity kappa", "J", m.kappa_J, 0.0, kMaxKappa_J);
  return p;
}

NetworkParameters checked_network_parameters(const ModelCli& m) {
  NetworkParameters p;
  naming_options(model_option_names(), [&] {
    p = to_network_parameters(m);
    return 0;
  });
  return p;
}

}  // namespace rbc::app
