// SPDX-License-Identifier: GPL-3.0-or-later
#include "homogenise/moduli_study.hpp"

#include <algorithm>
#include <random>
#include <stdexcept>

#include "core/validation.hpp"
#include "homogenise/disordered_network.hpp"
#include "homogenise/lattice_density.hpp"
#include "homogenise/moduli.hpp"

namespace rbc {

void Theorem3Options::validate() const {
  for (int i = 0; i < 4; ++i)
    require_finite_in_range("Theorem 3 deformation gradient entry", "", F.data()[i], -kUnbounded,
                            kUnbounded);
  require_finite_in_range("Theorem 3 deformation gradient determinant", "", F.determinant(), 0.0,
                          kUnbounded);
  require_finite_in_range("Theorem 3 start amplitude (Lbar)", "", start_amplitude_over_lbar, 0.0,
                          0.5, Ends::closed_closed);
}

Theorem3Check theorem3_check(const PeriodicNetwork& net, const NetworkMaterial& m, double lbar_um,
                             const Theorem3Options& o) {
  o.validate();
  std::mt19937 rng(o.seed);
  const double a = o.start_amplitude_over_lbar * lbar_um;
  std::uniform_real_distribution<double> u(-a, a);
  Eigen::Matrix2Xd U0(2, net.vertex_count());
  for (int i = 0; i < U0.size(); ++i) U0.data()[i] = u(rng);
  Theorem3Check c;
  c.relax = relax_patch(net, m, o.F, U0);
  c.psi_lattice_pN_per_um = lattice_density(m.w, m.C_pN_per_um, m.steric, o.F);
  c.psi_patch_pN_per_um = c.relax.energy_pNum / net.reference_area_um2();
  c.max_displacement_over_lbar = c.relax.max_displacement_um / lbar_um;
  c.start_amplitude_over_lbar = o.start_amplitude_over_lbar;
  return c;
}

std::string to_string(ModuliNetwork n) {
  return n == ModuliNetwork::hexagonal ? "hex" : "disordered";
}

ModuliNetwork moduli_network_from_string(const std::string& s) {
  if (s == "hex") return ModuliNetwork::hexagonal;
  if (s == "disordered") return ModuliNetwork::disordered;
  throw std::invalid_argument("network '" + s + "' is not one of hex, disordered");
}

void ModuliStudyOptions::validate() const {
  require_finite_in_range("disorder X", "", disorder, 0.0, 1.0, Ends::closed_closed);
  require_integer_in_range("disordered network seeds", seeds, 1, 1000);
  if (network == ModuliNetwork::hexagonal)
    require_integer_in_range("hexagonal patch cells", cells, 0, kMaxHexagonalPatchCells);
  else
    require_integer_in_range("disordered network cells", cells, 0, 200);
  theorem3.validate();
}

ModuliStudy run_moduli_study(const WlcParameters& wlc, const StericParameters& steric,
                             const ModuliStudyOptions& o, const ProgressSink& progress) {
  o.validate();
  const NetworkMaterial m = make_network_material(wlc, steric);
  const LinearModuli closed = closed_form_moduli(m.w, steric);
  const LinearModuli explicit_forms = paper_explicit_moduli(wlc, steric);
  ModuliStudy out;
  nlohmann::json& j = out.json;
  j = {{"network", to_string(o.network)},
       {"mu_closed_pN_per_um", closed.mu_pN_per_um},
       {"K_closed_pN_per_um", closed.K_pN_per_um},
       {"young_closed_pN_per_um", closed.young_pN_per_um()},
       {"poisson_closed", closed.poisson()},
       {"mu_paper_formula_pN_per_um", explicit_forms.mu_pN_per_um},
       {"K_paper_formula_pN_per_um", explicit_forms.K_pN_per_um},
       {"steric_C_pN_per_um", m.C_pN_per_um}};
  if (o.network == ModuliNetwork::hexagonal) {
    const int n = o.cells > 0 ? o.cells : 4;
    const PeriodicNetwork net = make_hexagonal_patch(n, wlc.lbar_um);
    const HomogenisedState h = homogenise_patch(net, m, Eigen::Matrix2d::Identity());
    const LinearModuli num = moduli_from_tangent(h.relaxed_tangent);
    const Theorem3Check t = theorem3_check(net, m, wlc.lbar_um, o.theorem3);
    const CellRelaxResult& r = t.relax;
    j.update({{"mu_numeric_pN_per_um", num.mu_pN_per_um},
              {"K_numeric_pN_per_um", num.K_pN_per_um},
              {"young_pN_per_um", num.young_pN_per_um()},
              {"poisson", num.poisson()},
              {"cells", n},
              {"mu_relative_difference", num.mu_pN_per_um / closed.mu_pN_per_um - 1.0},
              {"K_relative_difference", num.K_pN_per_um / closed.K_pN_per_um - 1.0},
              {"max_internal_displacement_um", r.max_displacement_um},
              {"max_internal_displacement_over_lbar", t.max_displacement_over_lbar},
              {"relaxation_start_amplitude_over_lbar", t.start_amplitude_over_lbar},
              {"psi_patch_over_lattice_minus_1", t.psi_relative_difference()},
              {"newton_iterations", r.iterations},
              {"residual_pN", r.residual_pN},
              {"converged", r.converged() && h.relax.converged()}});
    out.converged = r.converged() && h.relax.converged();
    if (!out.converged)
      out.failure = "cell problem did not converge: " + to_string(r.status) + ", residual " +
                    format_scientific(r.residual_pN) + " pN";
    return out;
  }
  DisorderOptions d;
  d.cells = o.cells > 0 ? o.cells : 12;
  d.disorder = o.disorder;
  d.spacing_um = wlc.lbar_um;
  d.validate();
  const std::vector<DisorderedSample> samples = disordered_study(d, m, o.seeds, 1, {}, progress);
  auto stat = [&](auto get) {
    std::vector<double> v;
    for (const auto& s : samples) v.push_back(get(s));
    return mean_std(v);
  };
  const MeanStd deg6 = stat([](const DisorderedSample& s) { return s.degree6_fraction; });
  const MeanStd mu = stat([](const DisorderedSample& s) { return s.relaxed.mu_pN_per_um; });
  const MeanStd K = stat([](const DisorderedSample& s) { return s.relaxed.K_pN_per_um; });
  const MeanStd mua = stat([](const DisorderedSample& s) { return s.affine.mu_pN_per_um; });
  const MeanStd Ka = stat([](const DisorderedSample& s) { return s.affine.K_pN_per_um; });
  const MeanStd E = stat([](const DisorderedSample& s) { return s.relaxed.young_pN_per_um(); });
  const MeanStd nu = stat([](const DisorderedSample& s) { return s.relaxed.poisson(); });
  const MeanStd pre = stat([](const DisorderedSample& s) { return s.prestress_pN_per_um; });
  const MeanStd phi = stat([](const DisorderedSample& s) { return s.phi_over_area; });
  double worst_residual = 0.0;
  bool converged = true;
  for (const auto& s : samples) {
    worst_residual = std::max(worst_residual, s.relax.residual_pN);
    converged = converged && s.relax.converged();
  }
  j.update({{"mu_numeric_pN_per_um", mu.mean},
            {"mu_numeric_std_pN_per_um", mu.std},
            {"K_numeric_pN_per_um", K.mean},
            {"K_numeric_std_pN_per_um", K.std},
            {"young_pN_per_um", E.mean},
            {"young_std_pN_per_um", E.std},
            {"poisson", nu.mean},
            {"poisson_std", nu.std},
            {"mu_affine_pN_per_um", mua.mean},
            {"mu_affine_std_pN_per_um", mua.std},
            {"K_affine_pN_per_um", Ka.mean},
            {"K_affine_std_pN_per_um", Ka.std},
            {"degree6_fraction", deg6.mean},
            {"degree6_fraction_std", deg6.std},
            {"prestress_pN_per_um", pre.mean},
            {"prestress_std_pN_per_um", pre.std},
            {"phi_over_area", phi.mean},
            {"disorder", d.disorder},
            {"cells", d.cells},
            {"rows", disordered_rows(d.cells)},
            {"row_distortion", disordered_row_distortion(d.cells)},
            {"vertices", samples.front().vertices},
            {"seeds", o.seeds},
            {"worst_residual_pN", worst_residual},
            {"converged", converged}});
  out.phi_over_area_std = phi.std;
  out.converged = converged;
  if (!converged)
    out.failure = "relaxation did not converge for every seed, worst residual " +
                  format_scientific(worst_residual) + " pN";
  return out;
}

}  // namespace rbc
