// SPDX-License-Identifier: GPL-3.0-or-later
// The joint posterior of two stretch tables simulated inside the test with the project's own
// model (continuum:2:200) at parameters the inference is not told: its 90 % intervals contain
// the truth, and that of mu (the combination the data determine) is narrower than either
// table's alone. Laplace-IS (calibrate/laplace_is.hpp): a few seconds per posterior at one
// thread.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iostream>
#include <random>

#include "calibrate/forward_model.hpp"
#include "calibrate/infer.hpp"
#include "core/units.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

/// A stretch table of the model's diameters at `truth` plus Gaussian noise of sd `noise_um`
/// (seeded), error bars = noise_um.
std::string simulate(const std::filesystem::path& dir, const std::string& stem,
                     const std::vector<double>& forces, const ForwardParameters& truth,
                     double noise_um, unsigned seed) {
  ForwardOptions fo;
  fo.method = parse_method("continuum:2:200");
  fo.forces_pN = forces;
  const ForwardModel model(fo);
  const ForwardRun run = model.run(truth);
  EXPECT_TRUE(run.converged);
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> noise(0.0, noise_um);
  const std::string path = (dir / (stem + ".csv")).string();
  std::ofstream out(path);
  out << "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n";
  for (size_t k = 0; k < forces.size(); ++k) {
    const double a = run.diameters.axial_um[k] + noise(gen);
    const double t = k == 0 ? a : run.diameters.transverse_um[k] + noise(gen);
    out << forces[k] << "," << a << "," << noise_um << "," << t << "," << noise_um << "\n";
  }
  return path;
}

InferenceResult fit(const std::vector<std::string>& files) {
  InferOptions o;
  o.data_files = files;
  o.method = parse_method("continuum:2:200");
  o.parameters = {Parameter::persistence, Parameter::lmax};
  // The box test_recovery.cpp checked to converge at this mesh and these forces.
  o.priors = {{Parameter::persistence, 3, 16}, {Parameter::lmax, 150, 300}};
  o.sampler_kind = SamplerKind::laplace_is;
  o.is_samples = 800;  // table b keeps 37 effective samples of 400: under the floor of 50
  o.sampler.seed = 3;
  o.threads = 1;
  return run_inference(o);
}

// Truth p = 9 nm, Lmax = 190 nm (mu = 10.0 uN/m); noise 0.1 um; seeds fixed, not selected. The
// check "truth inside the 90 % interval" fails with probability ~10 % per parameter for a
// calibrated posterior over new noise draws; with the seeds fixed the test is deterministic.
TEST(JointRecovery, JointIntervalsHoldTheTruthAndMuIsNarrowerThanFromEitherTable) {
  const auto dir = testing::fresh_output_dir("joint_recovery");
  ForwardParameters truth;
  truth.persistence_nm = 9.0;
  truth.lmax_nm = 190.0;
  const double truth_mu = sample_moduli(truth).mu_pN_per_um * units::uN_per_m_per_pN_per_um;
  const std::string a = simulate(dir, "synthetic_a", {0, 20, 50, 100, 150}, truth, 0.1, 21);
  const std::string b = simulate(dir, "synthetic_b", {0, 30, 75, 120, 150}, truth, 0.1, 22);
  const InferenceResult ra = fit({a}), rb = fit({b}), rj = fit({a, b});
  for (const InferenceResult* r : {&ra, &rb, &rj}) {
    std::cout << (r == &rj   ? "joint"
                  : r == &ra ? "a"
                             : "b")
              << ": mu " << r->mu.q50 << " [" << r->mu.q05 << ", " << r->mu.q95 << "], p "
              << r->parameters[0].q50 << " [" << r->parameters[0].q05 << ", "
              << r->parameters[0].q95 << "], lmax " << r->parameters[1].q50 << " ["
              << r->parameters[1].q05 << ", " << r->parameters[1].q95 << "], ESS " << r->ess
              << ", forward runs " << r->counts.runs << "\n";
    ASSERT_EQ(r->status, TmcmcStatus::converged) << to_string(r->status);
  }
  EXPECT_EQ(rj.experiments.size(), 2u);
  const double t[2] = {truth.persistence_nm, truth.lmax_nm};
  for (int k = 0; k < 2; ++k) {
    EXPECT_LE(rj.parameters[k].q05, t[k]) << rj.names[k];
    EXPECT_GE(rj.parameters[k].q95, t[k]) << rj.names[k];
  }
  EXPECT_LE(rj.mu.q05, truth_mu);
  EXPECT_GE(rj.mu.q95, truth_mu);
  const double wj = rj.mu.q95 - rj.mu.q05;
  EXPECT_LT(wj, ra.mu.q95 - ra.mu.q05);
  EXPECT_LT(wj, rb.mu.q95 - rb.mu.q05);
}

}  // namespace
}  // namespace rbc
