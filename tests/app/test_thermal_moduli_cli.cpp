// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc moduli --sampling-temperature T`: bad options refused with exit 2 and one line naming the
// option before any work; a small run gives the documented JSON (run record, thermal keys), the
// same numbers on one and two threads, and at T = 0 the zero-temperature moduli.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "app/cli_run.hpp"

namespace {
using rbc::testing::run_rbc;

TEST(ThermalModuliCli, RefusesBadOptionsWithExit2) {
  const struct {
    std::string args, option;
  } cases[] = {
      {"--sampling-temperature -1", "--sampling-temperature -1"},
      {"--sampling-temperature 2000", "--sampling-temperature 2000"},
      {"--sampling-temperature nan", "--sampling-temperature"},
      {"--sampling-temperature 300 --strain 0", "--strain 0"},
      {"--sampling-temperature 300 --strain 0.5", "--strain 0.5"},
      {"--sampling-temperature 300 --sweeps 10", "--sweeps 10"},  // fewer than the 20 batches
      {"--sampling-temperature 300 --batches 2", "--batches"},
      {"--sampling-temperature 300 --warmup-sweeps -5", "--warmup-sweeps"},
      {"--sampling-temperature 300 --cells 2", "--cells 2"},
      {"--sampling-temperature 300 --seed -1", "--seed"},
  };
  for (const auto& c : cases) {
    const rbc::testing::CliRun r = run_rbc("moduli " + c.args + " --json");
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.all();
    EXPECT_NE(r.err.find("rbc: error: "), std::string::npos) << c.args << "\n" << r.all();
    EXPECT_NE(r.err.find(c.option), std::string::npos) << c.args << "\n" << r.all();
    EXPECT_TRUE(r.out.empty()) << c.args << "\n" << r.out;
  }
}

TEST(ThermalModuliCli, JsonRunIsThreadIndependent) {
  const std::string args =
      "moduli --sampling-temperature 300 --cells 4 --sweeps 200 --warmup-sweeps 50 --seed 3 "
      "--json -q";
  const rbc::testing::CliRun one = run_rbc(args, 1), two = run_rbc(args, 2);
  ASSERT_EQ(one.exit_code, 0) << one.all();
  ASSERT_EQ(two.exit_code, 0) << two.all();
  const nlohmann::json a = nlohmann::json::parse(one.out), b = nlohmann::json::parse(two.out);
  for (const char* key :
       {"command", "config", "provenance", "mu_pN_per_um", "mu_error_pN_per_um", "K_pN_per_um",
        "K_error_pN_per_um", "mu_gamma_pN_per_um", "K_gamma_pN_per_um", "mu_relative_shift",
        "equipartition_ratio", "sampling_temperature_K", "wlc_temperature_K", "vertices"})
    EXPECT_TRUE(a.contains(key)) << key;
  EXPECT_EQ(a.at("vertices").get<int>(), 16);
  EXPECT_EQ(a.at("sampling_temperature_K").get<double>(), 300.0);
  EXPECT_EQ(a.at("mu_pN_per_um").get<double>(), b.at("mu_pN_per_um").get<double>());
  EXPECT_EQ(a.at("K_pN_per_um").get<double>(), b.at("K_pN_per_um").get<double>());
  EXPECT_EQ(a.at("mu_error_pN_per_um").get<double>(), b.at("mu_error_pN_per_um").get<double>());
  // The Gamma limit of the hexagonal patch is the closed form (Theorem 3).
  EXPECT_NEAR(a.at("mu_gamma_pN_per_um").get<double>() / a.at("mu_closed_pN_per_um").get<double>(),
              1.0, 1e-9);
}

TEST(ThermalModuliCli, ZeroTemperatureIsTheCentralDifference) {
  const rbc::testing::CliRun r = run_rbc("moduli --sampling-temperature 0 --json -q");
  ASSERT_EQ(r.exit_code, 0) << r.all();
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("mu_pN_per_um").get<double>(),
            j.at("mu_zero_temperature_cd_pN_per_um").get<double>());
  EXPECT_EQ(j.at("mu_error_pN_per_um").get<double>(), 0.0);
  EXPECT_NEAR(j.at("mu_relative_shift").get<double>(), 0.0, 1e-4);  // O(eps^2) truncation
  EXPECT_NEAR(j.at("K_relative_shift").get<double>(), 0.0, 1e-4);
}

}  // namespace
