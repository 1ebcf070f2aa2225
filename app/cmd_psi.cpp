// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc psi`: tabulates the homogenised density Psi and its stress along a deformation path,
// so the Taylor orders and the full WLC can be compared where they part (MODEL.md
// section 3; Hartmann 2008 Sec. 3.4, Appendix A), or evaluates Psi at one deformation.
#include <Eigen/Eigenvalues>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/run_config.hpp"
#include "core/io.hpp"
#include "core/validation.hpp"
#include "homogenise/invariant_laws.hpp"
#include "homogenise/lattice_density.hpp"
#include "homogenise/membrane_inputs.hpp"

namespace rbc::app {

void add_membrane_options(CLI::App* cmd, MembraneInputs& m);  // cmd_moduli.cpp
const OptionNames& membrane_option_names();                   // cmd_moduli.cpp

namespace {

struct PsiCli {
  MembraneInputs membrane;
  std::string order = "full";
  std::string curve = "uniaxial";
  std::string out;
  std::string deformation;
  int points = 200;
  bool json = false;
  /// What produced the run: command, resolved configuration, provenance (app/run_config.hpp);
  /// --json includes it, the CSV's comment lines carry it.
  nlohmann::json record;
};

/// F along a path at parameter s: uniaxial diag(s, 1), equibiaxial s I, simple shear
/// [[1, s], [0, 1]]. Largest principal stretch l1(s) = s, s, s/2 + sqrt(1 + s^2/4).
Eigen::Matrix2d path_deformation(const std::string& curve, double s) {
  Eigen::Matrix2d F = Eigen::Matrix2d::Identity();
  if (curve == "uniaxial")
    F(0, 0) = s;
  else if (curve == "equibiaxial")
    F *= s;
  else
    F(0, 1) = s;
  return F;
}
/// dF/ds along the path.
Eigen::Matrix2d path_tangent(const std::string& curve) {
  Eigen::Matrix2d D = Eigen::Matrix2d::Zero();
  if (curve == "uniaxial")
    D(0, 0) = 1;
  else if (curve == "equibiaxial")
    D = Eigen::Matrix2d::Identity();
  else
    D(0, 1) = 1;
  return D;
}

Eigen::Matrix2d parse_deformation(const std::string& text) {
  std::vector<double> v;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    const std::optional<double> x = parse_finite_number(item);
    if (!x)
      throw std::invalid_argument("--deformation entry '" + item + "' is not a finite number");
    v.push_back(*x);
  }
  if (v.size() != 4)
    throw std::invalid_argument("--deformation needs 4 numbers F11,F12,F21,F22, got " +
                                std::to_string(v.size()));
  Eigen::Matrix2d F;
  F << v[0], v[1], v[2], v[3];
  if (!(F.determinant() > 0))
    throw std::invalid_argument("--deformation must have det F > 0, got det F = " +
                                std::to_string(F.determinant()));
  return F;
}

int run_psi(const PsiCli& o) {
  const WlcParameters p = o.membrane.wlc();
  const StericParameters s = o.membrane.steric();
  const WlcExpansion e = wlc_expansion_from_string(o.order);
  const IsotropicMembraneLaw law = make_membrane_law(p, s, e);
  const WlcDensity w = make_wlc_density(p, e);
  const double C = steric_constant(w, s);
  if (o.json && o.deformation.empty())
    throw std::invalid_argument(
        "--json: expected --deformation F11,F12,F21,F22 too (the JSON is the evaluation at one "
        "F)");
  if (o.deformation.empty() && o.out.empty())
    throw std::invalid_argument("--out FILE.csv is required (or give --deformation)");
  if (!o.out.empty()) check_output_file(o.out, "--out");
  if (!o.deformation.empty()) {
    const Eigen::Matrix2d F = parse_deformation(o.deformation);
    const Invariants I = invariants(F);
    const InvariantDerivatives d = law.evaluate(I.i1, I.i2);
    const Eigen::Matrix2d P = first_piola(F, d);
    const double psi_lattice = lattice_density(w, C, s, F);
    if (!std::isfinite(d.psi) || !P.allFinite() || !std::isfinite(psi_lattice)) {
      // Outside the law's domain (the full WLC diverges where a link direction reaches Lmax).
      const double stretch =
          std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(F.transpose() * F)
                        .eigenvalues()
                        .maxCoeff());
      throw std::invalid_argument(
          "--deformation " + o.deformation + ": outside the domain of " + law.name +
          ": the largest principal stretch " + format_number(stretch) +
          " must be < Lmax/Lbar = " + format_number(1.0 / w.x0) + " (Psi is infinite there)");
    }
    if (o.json) {
      // The keys of rbc.psi() in Python: each names its unit, or is dimensionless (I1, I2).
      nlohmann::json j = o.record;
      j.update({{"law", law.name},
                {"I1", I.i1},
                {"I2", I.i2},
                {"psi_pN_per_um", d.psi},
                {"dpsi_dI1_pN_per_um", d.d1},
                {"dpsi_dI2_pN_per_um", d.d2},
                {"first_piola_pN_per_um", {{P(0, 0), P(0, 1)}, {P(1, 0), P(1, 1)}}},
                {"psi_lattice_pN_per_um", psi_lattice}});
      std::cout << j.dump(2) << "\n";
    } else {
      std::cout << std::setprecision(10) << "law: " << law.name << "\nI1 = " << I.i1
                << ", I2 = " << I.i2 << "\nPsi = " << d.psi
                << " pN/um (lattice at phi = 0: " << psi_lattice << ")\nP = [[" << P(0, 0) << ", "
                << P(0, 1) << "], [" << P(1, 0) << ", " << P(1, 1) << "]] pN/um\n";
    }
    if (o.out.empty()) return 0;
  }

  // Path end: where the full WLC diverges, largest principal stretch 1/x0.
  const double lmax_stretch = 1.0 / w.x0;
  const double s0 = o.curve == "shear" ? 0.0 : 1.0;
  const double s1 = o.curve == "shear" ? lmax_stretch - 1.0 / lmax_stretch : lmax_stretch;
  const Eigen::Matrix2d D = path_tangent(o.curve);
  CsvTable t;
  t.comments = {
      "rbc psi: homogenised density along a " + o.curve + " path; law: " + law.name,
      "Lbar " + std::to_string(o.membrane.lbar_nm) + " nm, Lmax " +
          std::to_string(o.membrane.lmax_nm) + " nm, p " +
          std::to_string(o.membrane.persistence_nm) + " nm, T " +
          std::to_string(o.membrane.temperature_K) + " K, q " + std::to_string(s.q) + ", eta " +
          std::to_string(s.eta),
      "s: stretch (uniaxial F = diag(s,1), equibiaxial F = s I) or shear (F = [[1,s],[0,1]]);"
      " the full WLC diverges at s = " +
          std::to_string(s1),
      "units in the column names (pN/um = uN/m); s, I1, I2 dimensionless; P = dPsi/dF "
      "(first Piola); dpsi_ds = P : dF/ds; psi_lattice: un-averaged lattice density at phi = 0"};
  for (const std::string& line : record_comment_lines(o.record)) t.comments.push_back(line);
  t.header = {"s",
              "I1",
              "I2",
              "psi_pN_per_um",
              "dpsi_ds_pN_per_um",
              "P11_pN_per_um",
              "P12_pN_per_um",
              "P21_pN_per_um",
              "P22_pN_per_um",
              "psi_lattice_pN_per_um"};
  for (int k = 0; k < o.points; ++k) {
    const double sv = s0 + (s1 - s0) * k / o.points;  // stops one step short of the divergence
    const Eigen::Matrix2d F = path_deformation(o.curve, sv);
    const Invariants I = invariants(F);
    const InvariantDerivatives d = law.evaluate(I.i1, I.i2);
    const Eigen::Matrix2d P = first_piola(F, d);
    t.rows.push_back({sv, I.i1, I.i2, d.psi, (P.array() * D.array()).sum(), P(0, 0), P(0, 1),
                      P(1, 0), P(1, 1), lattice_density(w, C, s, F)});
  }
  write_csv(o.out, t);
  if (o.json) return 0;  // stdout holds the JSON only
  std::cout << "wrote " << o.points << " rows (" << law.name << ", " << o.curve << ", s from " << s0
            << " to " << t.rows.back()[0] << ") to " << o.out << "\n";
  return 0;
}

}  // namespace

void add_psi_command(CLI::App& app, Action& action) {
  auto o = std::make_shared<PsiCli>();
  auto* cmd = app.add_subcommand("psi", "Tabulate the homogenised density Psi and its stress");
  add_config_option(cmd);
  add_membrane_options(cmd, o->membrane);
  cmd->add_option("--order", o->order, "2 | 3 | 4 | full (Taylor order of V, or the full WLC)")
      ->check(CLI::IsMember({"2", "3", "4", "full"}))
      ->capture_default_str();
  cmd->add_option("--curve", o->curve, "uniaxial | equibiaxial | shear")
      ->check(CLI::IsMember({"uniaxial", "equibiaxial", "shear"}))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "CSV file to write (atomically)")->check(nonempty_path());
  cmd->add_option("--points", o->points, "rows along the path, 2 to 100,000")
      ->check(integer_in(2, 100000))
      ->capture_default_str();
  cmd->add_option("--deformation", o->deformation,
                  "evaluate at one F given as F11,F12,F21,F22 (det F > 0, inside the law's "
                  "domain) and print");
  cmd->add_flag("--json", o->json,
                "with --deformation: print JSON: the run record (command, config, provenance) and "
                "the keys of rbc.psi() in Python (law, I1, I2, psi_pN_per_um, "
                "dpsi_dI1_pN_per_um, dpsi_dI2_pN_per_um, first_piola_pN_per_um, "
                "psi_lattice_pN_per_um)");
  cmd->callback([o, cmd, &action] {
    o->record = run_record(*cmd);
    action = [o] { return naming_options(membrane_option_names(), [&] { return run_psi(*o); }); };
  });
}

}  // namespace rbc::app
