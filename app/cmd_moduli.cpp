// `rbc moduli`: closed-form and numerically homogenised moduli of the spectrin network
// (MODEL.md section 3; Hartmann 2008 Sec. 3.2-3.4, 4.3), for the perfect hexagonal lattice
// or for disordered periodic networks.
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "core/validation.hpp"
#include "homogenise/disordered_network.hpp"
#include "homogenise/lattice_density.hpp"
#include "homogenise/membrane_inputs.hpp"
#include "homogenise/moduli.hpp"
#include "homogenise/periodic_network.hpp"

namespace rbc::app {

/// Registers --lbar --lmax --persistence --temperature --q --eta (used by cmd_psi.cpp too).
void add_membrane_options(CLI::App* cmd, MembraneInputs& m) {
  cmd->add_option("--lbar", m.lbar_nm, "spectrin rest length Lbar (nm), in (0, 10000]")
      ->capture_default_str();
  cmd->add_option("--lmax", m.lmax_nm, "spectrin contour length Lmax (nm), in (Lbar, 10000]")
      ->capture_default_str();
  cmd->add_option("--persistence", m.persistence_nm, "persistence length p (nm), in (0, 10000]")
      ->capture_default_str();
  cmd->add_option("--temperature", m.temperature_K, "temperature T (K), in (0, 1000]")
      ->capture_default_str();
  cmd->add_option("--q", m.q, "steric exponent q, in (0, 10]")->capture_default_str();
  cmd->add_option("--eta", m.eta, "steric regularisation eta, in (0, 1]")->capture_default_str();
}

/// The membrane quantities -> their options (shared with cmd_psi.cpp).
const OptionNames& membrane_option_names() {
  static const OptionNames names = {
      {"Lbar (rest length)", "--lbar"},
      {"Lmax (contour length, > Lbar)", "--lmax"},
      {"persistence length", "--persistence"},
      {"temperature", "--temperature"},
      {"steric exponent q", "--q"},
      {"steric regularisation eta", "--eta"},
      {"disorder X", "--disorder"},
      {"disordered network cells", "--cells"},
  };
  return names;
}

namespace {

struct ModuliCli {
  MembraneInputs membrane;
  std::string network = "hex";
  double disorder = 0.5;
  int cells = 0;  // 0: 4 for hex, 12 for disordered
  int seeds = 4;
  bool json = false, quiet = false;
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

int run_moduli(const ModuliCli& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const WlcParameters wlc = o.membrane.wlc();
  const StericParameters steric = o.membrane.steric();
  require_finite_in_range("disorder X", "", o.disorder, 0.0, 1.0, Ends::closed_closed);
  const NetworkMaterial m = make_network_material(wlc, steric);
  const LinearModuli closed = closed_form_moduli(m.w, steric);
  const LinearModuli explicit_forms = paper_explicit_moduli(wlc, steric);
  nlohmann::json j = {{"units", "uN/m (= pN/um)"},
                      {"network", o.network},
                      {"mu_closed", closed.mu_pN_per_um},
                      {"K_closed", closed.K_pN_per_um},
                      {"young_closed", closed.young_pN_per_um()},
                      {"poisson_closed", closed.poisson()},
                      {"mu_paper_formula", explicit_forms.mu_pN_per_um},
                      {"K_paper_formula", explicit_forms.K_pN_per_um},
                      {"steric_C", m.C_pN_per_um}};
  std::ostringstream text;
  text << std::setprecision(6) << "closed form (Sec. 4.3): mu = " << closed.mu_pN_per_um
       << " uN/m, K = " << closed.K_pN_per_um << " uN/m, Young " << closed.young_pN_per_um()
       << " uN/m, Poisson " << closed.poisson() << "  (steric C = " << m.C_pN_per_um << " pN/um)\n";
  int status = 0;
  if (o.network == "hex") {
    const int n = o.cells > 0 ? o.cells : 4;
    if (n > kMaxHexagonalPatchCells)
      throw std::invalid_argument("--cells must be <= " + std::to_string(kMaxHexagonalPatchCells) +
                                  " for the hexagonal patch, got " + std::to_string(n));
    const PeriodicNetwork net = make_hexagonal_patch(n, wlc.lbar_um);
    const HomogenisedState h = homogenise_patch(net, m, Eigen::Matrix2d::Identity());
    const LinearModuli num = moduli_from_tangent(h.relaxed_tangent);
    // Theorem 3: relax a deformed patch from a random non-affine start; the affine map
    // must come back. F is a generic finite deformation.
    Eigen::Matrix2d F;
    F << 1.3, 0.2, -0.1, 0.9;
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> u(-0.1 * wlc.lbar_um, 0.1 * wlc.lbar_um);
    Eigen::Matrix2Xd U0(2, net.vertex_count());
    for (int i = 0; i < U0.size(); ++i) U0.data()[i] = u(rng);
    const RelaxResult r = relax_patch(net, m, F, U0);
    const double psi_lattice = lattice_density(m.w, m.C_pN_per_um, steric, F);
    const double psi_patch = r.energy_pNum / net.reference_area_um2();
    j.update({{"mu_numeric", num.mu_pN_per_um},
              {"K_numeric", num.K_pN_per_um},
              {"young", num.young_pN_per_um()},
              {"poisson", num.poisson()},
              {"cells", n},
              {"mu_relative_difference", num.mu_pN_per_um / closed.mu_pN_per_um - 1.0},
              {"K_relative_difference", num.K_pN_per_um / closed.K_pN_per_um - 1.0},
              {"max_internal_displacement_um", r.max_displacement_um},
              {"max_internal_displacement_over_lbar", r.max_displacement_um / wlc.lbar_um},
              {"relaxation_start_amplitude_over_lbar", 0.1},
              {"psi_patch_over_lattice_minus_1", psi_patch / psi_lattice - 1.0},
              {"newton_iterations", r.iterations},
              {"residual_pN", r.residual_pN},
              {"converged", r.converged() && h.relax.converged()}});
    text << "numerical (" << n << " x " << n
         << " periodic hexagonal patch, Schur complement): mu = " << num.mu_pN_per_um
         << " uN/m, K = " << num.K_pN_per_um << " uN/m, Young " << num.young_pN_per_um()
         << " uN/m, Poisson " << num.poisson() << "\n"
         << std::setprecision(3) << "relative difference: mu "
         << num.mu_pN_per_um / closed.mu_pN_per_um - 1.0 << ", K "
         << num.K_pN_per_um / closed.K_pN_per_um - 1.0 << "\n"
         << "Theorem 3 check at F = [[1.3, 0.2], [-0.1, 0.9]] from a random start (0.1 Lbar): "
         << "largest internal displacement " << r.max_displacement_um / wlc.lbar_um
         << " Lbar after " << r.iterations
         << " Newton iterations, Psi_patch/Psi_lattice - 1 = " << psi_patch / psi_lattice - 1.0
         << "\n";
    if (!r.converged() || !h.relax.converged()) {
      std::cerr << "rbc: error: cell problem did not converge: " + to_string(r.status) +
                       ", residual " + format_scientific(r.residual_pN) + " pN\n";
      status = 1;
    }
  } else {
    DisorderOptions d;
    d.cells = o.cells > 0 ? o.cells : 12;
    d.disorder = o.disorder;
    d.spacing_um = wlc.lbar_um;
    d.validate();
    const auto ts = std::chrono::steady_clock::now();
    const std::vector<DisorderedSample> samples =
        disordered_study(d, m, o.seeds, 1, {}, stderr_progress(o.quiet));
    const double per_seed = seconds_since(ts) / o.seeds;
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
    j.update({{"mu_numeric", mu.mean},
              {"mu_numeric_std", mu.std},
              {"K_numeric", K.mean},
              {"K_numeric_std", K.std},
              {"young", E.mean},
              {"young_std", E.std},
              {"poisson", nu.mean},
              {"poisson_std", nu.std},
              {"mu_affine", mua.mean},
              {"mu_affine_std", mua.std},
              {"K_affine", Ka.mean},
              {"K_affine_std", Ka.std},
              {"degree6_fraction", deg6.mean},
              {"degree6_fraction_std", deg6.std},
              {"prestress_uN_per_m", pre.mean},
              {"prestress_std", pre.std},
              {"phi_over_area", phi.mean},
              {"disorder", d.disorder},
              {"cells", d.cells},
              {"rows", disordered_rows(d.cells)},
              {"row_distortion", disordered_row_distortion(d.cells)},
              {"vertices", samples.front().vertices},
              {"seeds", o.seeds},
              {"seconds_per_seed", per_seed},
              {"worst_residual_pN", worst_residual},
              {"converged", converged}});
    text << std::setprecision(5) << "disordered networks: X = " << d.disorder << ", " << d.cells
         << " x " << disordered_rows(d.cells) << " points (" << samples.front().vertices
         << " vertices), " << o.seeds << " seeds (mean +- std)\n"
         << "  degree-6 fraction " << deg6.mean << " +- " << deg6.std << ", Phi/A " << phi.mean
         << " +- " << phi.std << "\n"
         << "  affine (Cauchy-Born): mu = " << mua.mean << " +- " << mua.std << ", K = " << Ka.mean
         << " +- " << Ka.std << " uN/m\n"
         << "  relaxed:              mu = " << mu.mean << " +- " << mu.std << ", K = " << K.mean
         << " +- " << K.std << " uN/m, Young " << E.mean << " +- " << E.std << ", Poisson "
         << nu.mean << " +- " << nu.std << "\n"
         << "  relaxed / closed form: mu " << mu.mean / closed.mu_pN_per_um << ", K "
         << K.mean / closed.K_pN_per_um << "; residual isotropic tension " << pre.mean << " +- "
         << pre.std << " uN/m\n"
         << "  " << per_seed << " s per seed\n";
    if (!converged) {
      std::cerr << "rbc: error: relaxation did not converge for every seed, worst residual " +
                       format_scientific(worst_residual) + " pN\n";
      status = 1;
    }
  }
  j["seconds_total"] = seconds_since(t0);
  if (o.json)
    std::cout << j.dump(2) << "\n";
  else
    std::cout << text.str();
  return status;
}

}  // namespace

void add_moduli_command(CLI::App& app, Action& action) {
  auto o = std::make_shared<ModuliCli>();
  auto* cmd = app.add_subcommand(
      "moduli",
      "Closed-form and numerically homogenised shear/area moduli of the spectrin network");
  add_membrane_options(cmd, o->membrane);
  cmd->add_option("--network", o->network, "hex (perfect lattice) | disordered")
      ->check(CLI::IsMember({"hex", "disordered"}))
      ->capture_default_str();
  cmd->add_option("--disorder", o->disorder,
                  "disorder X in [0, 1]: jitter radius X * 0.4 * spacing (disordered only)")
      ->capture_default_str();
  cmd->add_option("--cells", o->cells,
                  "patch size n, at most 200 (default 4 for hex, 12 for disordered, which needs "
                  ">= 4)")
      ->check(integer_in(0, 200));
  cmd->add_option("--seeds", o->seeds, "number of random networks (disordered only), 1 to 1000")
      ->check(integer_in(1, 1000))
      ->capture_default_str();
  cmd->add_flag("--json", o->json,
                "print JSON (mu_closed, K_closed, mu_numeric, K_numeric, young, poisson; uN/m; "
                "young/poisson from the numerical moduli)");
  cmd->add_flag("--quiet,-q", o->quiet, "no progress lines on stderr");
  cmd->callback([o, &action] {
    action = [o] {
      return naming_options(membrane_option_names(), [&] { return run_moduli(*o); });
    };
  });
}

}  // namespace rbc::app
