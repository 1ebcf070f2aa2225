// SPDX-License-Identifier: GPL-3.0-or-later
// Typed stability rows: a value the sweep did not reach is written as "not reached" (CSV) and
// "reached": false without a value (JSON), never as inf, NaN or null.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "compare/stability.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(StabilityRows, UnreachedValuesAreNamedNeverNonFinite) {
  StabilityResult r;
  r.rows.push_back({StabilityStudy::taylor_order, "continuum p=2", "tolerance", 0.05,
                    StabilityMetric::departure_force_pN, std::nullopt, "not within the ladder"});
  r.rows.push_back({StabilityStudy::monte_carlo, "monte carlo N=150", "step_um", 0.1,
                    StabilityMetric::energy_inefficiency, std::numeric_limits<double>::infinity(),
                    ""});
  r.rows.push_back({StabilityStudy::solver_budget, "discrete N=150", "force_pN", 300,
                    StabilityMetric::iterations, 42.0, ""});
  const std::string dir = testing::fresh_output_dir("stability_rows_unreached").string();
  write_stability(r, dir);
  const std::string csv = slurp(dir + "/stability.csv");
  const std::string json_text = slurp(dir + "/stability.json");
  for (const char* bad : {"inf", "nan", "NaN", "null"}) {
    EXPECT_EQ(json_text.find(bad), std::string::npos) << bad;
  }
  EXPECT_EQ(csv.find(",inf,"), std::string::npos);
  EXPECT_NE(csv.find("taylor_order,continuum p=2,tolerance,0.05,departure_force_pN,not reached"),
            std::string::npos);
  const auto j = nlohmann::json::parse(json_text);
  ASSERT_EQ(j.size(), 3u);
  EXPECT_FALSE(j[0]["reached"].get<bool>());
  EXPECT_FALSE(j[0].contains("value"));
  EXPECT_FALSE(j[1]["reached"].get<bool>());
  EXPECT_TRUE(j[2]["reached"].get<bool>());
  EXPECT_EQ(j[2]["value"].get<double>(), 42.0);
  EXPECT_EQ(j[2]["metric"].get<std::string>(), "iterations");
  EXPECT_EQ(j[2]["study"].get<std::string>(), "solver_budget");
  std::filesystem::remove_all(dir);
}

TEST(StabilityRows, EveryMetricHasADistinctName) {
  std::set<std::string> names;
  const int last = static_cast<int>(StabilityMetric::coarsest_resolution);
  for (int m = 0; m <= last; ++m) {
    const std::string n = to_string(static_cast<StabilityMetric>(m));
    EXPECT_NE(n, "unknown");
    EXPECT_TRUE(names.insert(n).second) << n;
  }
}

}  // namespace
}  // namespace rbc
