// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc moduli`: closed-form and numerically homogenised moduli of the spectrin network
// (MODEL.md section 3; Hartmann 2008 Sec. 3.2-3.4, 4.3), for the perfect hexagonal lattice
// or for disordered periodic networks; with --sampling-temperature, the isothermal moduli of the
// periodic cell sampled at that temperature against the zero-temperature ones
// (homogenise/thermal_moduli.hpp).
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
#include "app/run_config.hpp"
#include "core/validation.hpp"
#include "homogenise/disordered_network.hpp"
#include "homogenise/lattice_density.hpp"
#include "homogenise/membrane_inputs.hpp"
#include "homogenise/moduli.hpp"
#include "homogenise/moduli_study.hpp"
#include "homogenise/periodic_network.hpp"
#include "homogenise/thermal_moduli.hpp"

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
      {"hexagonal patch cells", "--cells"},
      {"disordered network seeds", "--seeds"},
  };
  return names;
}

namespace {

struct ModuliCli {
  MembraneInputs membrane;
  ModuliNetwork network = ModuliNetwork::hexagonal;
  double disorder = 0.5;
  int cells = 0;  // 0: 4 for hex, 12 for disordered
  int seeds = 4;
  bool json = false, quiet = false;
  /// --sampling-temperature given: the thermal study (homogenise/thermal_moduli.hpp) runs.
  bool thermal = false;
  ThermalModuliOptions sampling;
  /// What produced the run: command, resolved configuration, provenance (app/run_config.hpp);
  /// --json includes it beside the study's keys.
  nlohmann::json record;
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// The thermal study's quantities -> options (with the membrane ones).
const OptionNames& thermal_option_names() {
  static const OptionNames names = [] {
    OptionNames n = membrane_option_names();
    n["sampling temperature"] = "--sampling-temperature";
    n["thermal moduli sweeps"] = "--sweeps";
    n["thermal moduli warm-up sweeps"] = "--warmup-sweeps";
    n["thermal moduli strain"] = "--strain";
    n["thermal moduli batches"] = "--batches";
    return n;
  }();
  return names;
}

int run_thermal(const ModuliCli& o) {
  const auto t0 = std::chrono::steady_clock::now();
  ThermalStudyOptions so;
  so.network = o.network;
  so.cells = o.cells;
  so.disorder = o.disorder;
  so.sampling = o.sampling;
  const WlcParameters wlc = o.membrane.wlc();
  const StericParameters steric = o.membrane.steric();
  so.validate();  // every option checked before any work
  nlohmann::json j = thermal_moduli_study(wlc, steric, so, stderr_progress(o.quiet));
  j["wall_s"] = seconds_since(t0);
  if (o.json) {
    nlohmann::json out = o.record;
    out.update(j);
    std::cout << out.dump(2) << "\n";
    return 0;
  }
  const auto num = [&](const char* key) { return j.at(key).get<double>(); };
  const auto pm = [&](const char* value, const char* error) {
    return format_with_error(num(value), num(error));
  };
  const auto percent = [&](const char* value, const char* error) {
    return format_with_error(100 * num(value), 100 * num(error)) + " %";
  };
  const int cells = j.at("cells").get<int>();
  std::ostringstream text;
  text << std::setprecision(6) << "closed form (Sec. 4.3): mu = " << num("mu_closed_pN_per_um")
       << " uN/m, K = " << num("K_closed_pN_per_um") << " uN/m\n"
       << (o.network == ModuliNetwork::hexagonal
               ? "periodic hexagonal patch " + std::to_string(cells) + " x " + std::to_string(cells)
               : "disordered network (X = " + format_number(num("disorder")) + ", seed 1, " +
                     std::to_string(cells) + " columns)")
       << ", " << j.at("vertices").get<int>() << " nodes\n"
       << "zero temperature (Gamma limit, relaxed cell): mu = " << num("mu_gamma_pN_per_um")
       << " uN/m, K = " << num("K_gamma_pN_per_um") << " uN/m\n";
  if (num("sampling_temperature_K") == 0.0) {
    text << "at T = 0 K (no sampling: central difference of the relaxed stress, strain "
         << num("strain") << "): mu = " << num("mu_pN_per_um")
         << " uN/m, K = " << num("K_pN_per_um") << " uN/m, isotropic tension "
         << num("tension_pN_per_um") << " uN/m\n";
  } else {
    text << "at T = " << num("sampling_temperature_K") << " K (Metropolis, "
         << j.at("sweeps").get<long long>() << " sweeps per chain, strain " << num("strain")
         << "): mu = " << pm("mu_pN_per_um", "mu_error_pN_per_um") << " uN/m ("
         << percent("mu_relative_shift", "mu_relative_shift_error")
         << "), K = " << pm("K_pN_per_um", "K_error_pN_per_um") << " uN/m ("
         << percent("K_relative_shift", "K_relative_shift_error") << ")\n"
         << "quasi-harmonic O(T) prediction: mu = " << num("mu_quasi_harmonic_pN_per_um")
         << " uN/m, K = " << num("K_quasi_harmonic_pN_per_um") << " uN/m\n"
         << "isotropic tension " << pm("tension_pN_per_um", "tension_error_pN_per_um")
         << " uN/m (T = 0: " << num("tension_zero_temperature_pN_per_um")
         << "), energy per degree of freedom / (kB T/2) "
         << pm("equipartition_ratio", "equipartition_ratio_error") << ", acceptance "
         << num("acceptance") << "\n";
  }
  std::cout << text.str();
  return 0;
}

int run_moduli(const ModuliCli& o) {
  if (o.thermal) return run_thermal(o);
  const auto t0 = std::chrono::steady_clock::now();
  const WlcParameters wlc = o.membrane.wlc();
  const StericParameters steric = o.membrane.steric();
  ModuliStudyOptions so;
  so.network = o.network;
  so.cells = o.cells;
  so.disorder = o.disorder;
  so.seeds = o.seeds;
  const ModuliStudy study = run_moduli_study(wlc, steric, so, stderr_progress(o.quiet));
  nlohmann::json j = study.json;
  const auto num = [&](const char* key) { return j.at(key).get<double>(); };
  std::ostringstream text;
  text << std::setprecision(6) << "closed form (Sec. 4.3): mu = " << num("mu_closed_pN_per_um")
       << " uN/m, K = " << num("K_closed_pN_per_um") << " uN/m, Young "
       << num("young_closed_pN_per_um") << " uN/m, Poisson " << num("poisson_closed")
       << "  (steric C = " << num("steric_C_pN_per_um") << " pN/um)\n";
  if (o.network == ModuliNetwork::hexagonal) {
    const int n = j.at("cells").get<int>();
    text << "numerical (" << n << " x " << n
         << " periodic hexagonal patch, Schur complement): mu = " << num("mu_numeric_pN_per_um")
         << " uN/m, K = " << num("K_numeric_pN_per_um") << " uN/m, Young " << num("young_pN_per_um")
         << " uN/m, Poisson " << num("poisson") << "\n"
         << std::setprecision(3) << "relative difference: mu " << num("mu_relative_difference")
         << ", K " << num("K_relative_difference") << "\n"
         << "Theorem 3 check at F = [[1.3, 0.2], [-0.1, 0.9]] from a random start (0.1 Lbar): "
         << "largest internal displacement " << num("max_internal_displacement_over_lbar")
         << " Lbar after " << j.at("newton_iterations").get<int>()
         << " Newton iterations, Psi_patch/Psi_lattice - 1 = "
         << num("psi_patch_over_lattice_minus_1") << "\n";
  } else {
    const double per_seed = seconds_since(t0) / o.seeds;
    j["wall_per_seed_s"] = per_seed;
    const int cells = j.at("cells").get<int>();
    text << std::setprecision(5) << "disordered networks: X = " << num("disorder") << ", " << cells
         << " x " << j.at("rows").get<int>() << " points (" << j.at("vertices").get<int>()
         << " vertices), " << o.seeds << " seeds (mean +- std)\n"
         << "  degree-6 fraction " << num("degree6_fraction") << " +- "
         << num("degree6_fraction_std") << ", Phi/A " << num("phi_over_area") << " +- "
         << study.phi_over_area_std << "\n"
         << "  affine (Cauchy-Born): mu = " << num("mu_affine_pN_per_um") << " +- "
         << num("mu_affine_std_pN_per_um") << ", K = " << num("K_affine_pN_per_um") << " +- "
         << num("K_affine_std_pN_per_um") << " uN/m\n"
         << "  relaxed:              mu = " << num("mu_numeric_pN_per_um") << " +- "
         << num("mu_numeric_std_pN_per_um") << ", K = " << num("K_numeric_pN_per_um") << " +- "
         << num("K_numeric_std_pN_per_um") << " uN/m, Young " << num("young_pN_per_um") << " +- "
         << num("young_std_pN_per_um") << ", Poisson " << num("poisson") << " +- "
         << num("poisson_std") << "\n"
         << "  relaxed / closed form: mu "
         << num("mu_numeric_pN_per_um") / num("mu_closed_pN_per_um") << ", K "
         << num("K_numeric_pN_per_um") / num("K_closed_pN_per_um")
         << "; residual isotropic tension " << num("prestress_pN_per_um") << " +- "
         << num("prestress_std_pN_per_um") << " uN/m\n"
         << "  " << per_seed << " s per seed\n";
  }
  if (!study.converged) std::cerr << "rbc: error: " + study.failure + "\n";
  j["wall_s"] = seconds_since(t0);
  if (o.json) {
    nlohmann::json out = o.record;
    out.update(j);
    std::cout << out.dump(2) << "\n";
  } else
    std::cout << text.str();
  return study.converged ? 0 : 1;
}

}  // namespace

void add_moduli_command(CLI::App& app, Action& action) {
  auto o = std::make_shared<ModuliCli>();
  auto* cmd = app.add_subcommand(
      "moduli",
      "Closed-form and numerically homogenised shear/area moduli of the spectrin network");
  add_config_option(cmd);
  add_membrane_options(cmd, o->membrane);
  cmd->add_option("--network", o->network, "hex (perfect lattice) | disordered")
      ->transform(enum_choice<ModuliNetwork>(
          {{"hex", ModuliNetwork::hexagonal}, {"disordered", ModuliNetwork::disordered}}))
      ->type_name("TEXT")
      ->default_str("hex");
  cmd->add_option("--disorder", o->disorder,
                  "disorder X in [0, 1]: jitter radius X * 0.4 * spacing (disordered only)")
      ->capture_default_str();
  cmd->add_option("--cells", o->cells,
                  "patch size n, at most 200 (default 4 for hex, 12 for disordered, which needs "
                  ">= 4; with --sampling-temperature 10 for hex, which needs >= 3)")
      ->check(integer_in(0, 200));
  cmd->add_option("--seeds", o->seeds,
                  "number of random networks (disordered only, zero-temperature study; the "
                  "thermal study samples the network of seed 1), 1 to 1000")
      ->check(integer_in(1, 1000))
      ->capture_default_str();
  cmd->add_flag("--json", o->json,
                "print JSON: the run record (command, config, provenance) and the study, whose "
                "every key names its unit (mu_closed_pN_per_um, K_closed_pN_per_um, "
                "mu_numeric_pN_per_um, K_numeric_pN_per_um, young_pN_per_um; pN/um = uN/m) or "
                "is dimensionless (poisson, *_relative_difference, *_over_lbar, counts); "
                "young/poisson from the numerical moduli; with --sampling-temperature the thermal "
                "keys (mu_pN_per_um, mu_error_pN_per_um, mu_gamma_pN_per_um, mu_relative_shift, "
                "the same for K, mu_quasi_harmonic_pN_per_um, tension_pN_per_um, "
                "equipartition_ratio, ...)");
  auto* sampling =
      cmd->add_option("--sampling-temperature", o->sampling.temperature_K,
                      "sample the periodic cell at this temperature (K), in [0, 1000], and "
                      "report the isothermal moduli against the zero-temperature ones (the WLC "
                      "constants keep --temperature); 0 gives the zero-temperature central "
                      "difference")
          ->type_name("FLOAT");
  cmd->add_option("--sweeps", o->sampling.sweeps,
                  "with --sampling-temperature: production sweeps per chain (six chains: three "
                  "strain directions, +-strain), at least --batches")
      ->check(integer_in(4, 1000000000))
      ->capture_default_str();
  cmd->add_option("--warmup-sweeps", o->sampling.warmup_sweeps,
                  "with --sampling-temperature: step-adaptation sweeps at F = I, then as many "
                  "burn-in sweeps per chain")
      ->check(integer_in(0, 1000000000))
      ->capture_default_str();
  cmd->add_option("--strain", o->sampling.strain,
                  "with --sampling-temperature: imposed strain eps of the central differences, in "
                  "(0, 0.05]")
      ->capture_default_str();
  cmd->add_option("--batches", o->sampling.batches,
                  "with --sampling-temperature: batches of the batch-means errors, 4 to 1000")
      ->check(integer_in(4, 1000))
      ->capture_default_str();
  cmd->add_option("--seed", o->sampling.seed,
                  "with --sampling-temperature: seed of the chains' mt19937 streams, an integer in "
                  "[0, 2^64 - 1]")
      ->check(unsigned_integer())
      ->capture_default_str();
  cmd->add_flag("--quiet,-q", o->quiet, "no progress lines on stderr");
  cmd->callback([o, cmd, sampling, &action] {
    o->record = run_record(*cmd);
    o->thermal = sampling->count() > 0;
    if (o->thermal) {
      action = [o] {
        return naming_options(thermal_option_names(), [&] { return run_moduli(*o); });
      };
      return;
    }
    action = [o] {
      return naming_options(membrane_option_names(), [&] { return run_moduli(*o); });
    };
  });
}

}  // namespace rbc::app
