// compare/: goodness of fit, reference extrapolation, Pareto front, and tiny end-to-end
// runs of fig7, tradeoff, stability and report checking the files people open.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "compare/report.hpp"
#include "core/io.hpp"

namespace rbc {
namespace {
namespace fs = std::filesystem;

std::string fresh_dir(const std::string& name) {
  const std::string dir = std::string(RBC_BINARY_DIR) + "/test_output/" + name;
  fs::remove_all(dir);
  return dir;
}

TEST(Compare, FitQualityAgainstSyntheticCurves) {
  const std::vector<ExperimentPoint> e = {{0, 8, 0.5, 8, 0.5}, {100, 12, 0.5, 5, 0.5}};
  std::vector<CurveSample> model = {{0, 8, 8}, {100, 12, 5}};
  FitQuality q = fit_quality(e, model);
  EXPECT_DOUBLE_EQ(q.axial_rms_um, 0.0);
  EXPECT_EQ(q.axial_inside, 2);
  model = {{0, 9, 8.2}, {50, 11, 6}, {100, 13, 5.2}};  // D_A 1 um high everywhere
  q = fit_quality(e, model);
  EXPECT_NEAR(q.axial_rms_um, 1.0, 1e-12);
  EXPECT_EQ(q.axial_inside, 0);
  EXPECT_NEAR(q.transverse_rms_um, 0.2, 1e-12);
  EXPECT_EQ(q.transverse_inside, 2);
  EXPECT_THROW(fit_quality(e, {{0, 8, 8}}), std::invalid_argument);  // does not cover 100 pN
}

TEST(Compare, RichardsonRecoversTheLimitOfAnInverseNSequence) {
  // D(N) = D_inf + c/N exactly: the two-point extrapolation is exact.
  std::vector<TradeoffRow> rows;
  for (int n : {500, 2000, 8000}) {
    TradeoffRow r;
    r.run.method = {MethodKind::discrete, n, WlcExpansion::full};
    r.run.vertices = n;
    r.axial_um = 11.8 - 40.0 / n;
    r.transverse_um = 6.1 + 10.0 / n;
    r.converged = true;
    rows.push_back(r);
  }
  const TradeoffReference ref = richardson_reference(rows);
  EXPECT_NEAR(ref.axial_um, 11.8, 1e-12);
  EXPECT_NEAR(ref.transverse_um, 6.1, 1e-12);
  EXPECT_NEAR(ref.axial_error_um, 40.0 / 8000, 1e-12);
}

TEST(Compare, ParetoFrontKeepsOnlyUndominatedRuns) {
  std::vector<TradeoffRow> rows(4);
  const double t[] = {1, 2, 3, 4}, err[] = {0.5, 0.6, 0.1, 0.2};
  for (int k = 0; k < 4; ++k) {
    rows[k].wall_s = t[k];
    rows[k].axial_error_um = err[k];
    rows[k].converged = true;
  }
  mark_pareto_front(rows);
  EXPECT_TRUE(rows[0].pareto);
  EXPECT_FALSE(rows[1].pareto);  // slower and worse than rows[0]
  EXPECT_TRUE(rows[2].pareto);
  EXPECT_FALSE(rows[3].pareto);
}

TEST(Compare, TinyReportWritesEveryFileWithSensibleNumbers) {
  const std::string dir = fresh_dir("report");
  ReportOptions o;
  o.fig7.forces_pN = {0, 100, 193};
  o.fig7.methods = {{MethodKind::discrete, 150, WlcExpansion::full},
                    {MethodKind::continuum, 300, WlcExpansion::order2}};
  o.tradeoff.force_pN = 50;
  o.tradeoff.discrete_vertices = {150, 300, 600};
  o.tradeoff.continuum_elements = {300, 600};
  o.tradeoff.continuum_orders = {WlcExpansion::order2};
  o.stability.discrete_vertices = 150;
  o.stability.continuum_elements = 300;
  o.stability.order_forces_pN = {0, 150, 400};
  o.stability.budget_forces_pN = {300, 1500};
  o.stability.etas = {5e-3, 5e-4};
  o.stability.qs = {1.0};
  o.stability.mc_vertices = 150;
  o.stability.mc_sweeps = 60;
  o.stability.mc_steps_um = {0.003, 0.1};
  o.stability.mc_temperatures_K = {300};
  o.mc_convergence.vertices = 150;
  o.mc_convergence.force_pN = 50;
  o.mc_convergence.mc_sweeps = 400;  // fixed work, not a wall-clock budget
  o.mc_convergence.sample_every_sweeps = 20;
  run_report(o, dir, {});
  for (const char* f :
       {"report.md", "fig7/fig7.png", "fig7/fig7_fit.csv", "fig7/fig7.json",
        "tradeoff/tradeoff.csv", "tradeoff/tradeoff_axial.png", "tradeoff/tradeoff_transverse.png",
        "stability/stability.csv", "stability/stability_orders.png", "tradeoff/mc_convergence.png",
        "tradeoff/mc_convergence.csv"})
    EXPECT_TRUE(fs::exists(dir + "/" + f)) << f;
  // No temporary file is left behind.
  for (const auto& e : fs::recursive_directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".partial-"), std::string::npos) << e.path();
  // Fig. 7 curves: finite, D_A increasing and D_T decreasing with force.
  const CsvTable d = read_csv(dir + "/fig7/fig7_discrete_N150.csv");
  ASSERT_EQ(d.rows.size(), 3u);
  for (size_t k = 1; k < d.rows.size(); ++k) {
    EXPECT_GT(d.rows[k][1], d.rows[k - 1][1]);
    EXPECT_LT(d.rows[k][2], d.rows[k - 1][2]);
  }
  // Trade-off: every run converged; at 50 pN every model of the cell is longer along the
  // force than across it (D_A > D_T), and all solve the same physics, so each lies within
  // 10 % of the reference D_A; the finest discrete network is closer to the reference than
  // the coarsest.
  const CsvTable t = read_csv(dir + "/tradeoff/tradeoff.csv");
  ASSERT_EQ(t.rows.size(), 5u);
  for (const auto& r : t.rows) {
    EXPECT_EQ(r[8], 1.0) << "converged";
    EXPECT_GT(r[5], r[6]) << "D_A > D_T";
    EXPECT_LT(r[9], 0.1 * r[5]) << "axial error within 10 % of D_A";
  }
  EXPECT_LT(t.rows[2][9], t.rows[0][9]);  // axial_error_um: N=600 vs N=150
  // Monte Carlo: a larger trial step is accepted less often.
  std::ifstream st(dir + "/stability/stability.csv");
  std::map<double, double> acceptance;  // step -> acceptance
  for (std::string line; std::getline(st, line);) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (cells.size() >= 6 && cells[0] == "monte_carlo" && cells[2] == "step_um" &&
        cells[4] == "acceptance")
      acceptance[std::stod(cells[3])] = std::stod(cells[5]);
  }
  ASSERT_EQ(acceptance.size(), 2u);
  EXPECT_GT(acceptance[0.003], acceptance[0.1]);
  // A limit the sweep never reached says so in words: no nan, inf or null in the files.
  for (const char* f : {"/stability/stability.csv", "/stability/stability.json"}) {
    std::ifstream in(dir + f);
    const std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    for (const char* bad : {",nan,", ",-nan,", ",inf,", ",-inf,", "null"})
      EXPECT_EQ(body.find(bad), std::string::npos) << f << " holds " << bad;
  }
  std::ifstream md(dir + "/report.md");
  const std::string text((std::istreambuf_iterator<char>(md)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("The paper's claims"), std::string::npos);
  EXPECT_NE(text.find("fig7/fig7.png"), std::string::npos);
  // The Monte Carlo time-to-accuracy subsection sits in the trade-off section, with its chart.
  const size_t mc_section = text.find("Monte Carlo against the minimiser");
  ASSERT_NE(mc_section, std::string::npos);
  EXPECT_GT(mc_section, text.find("## Speed against accuracy"));
  EXPECT_LT(mc_section, text.find("## Where methods stop working"));
  EXPECT_NE(text.find("tradeoff/mc_convergence.png"), std::string::npos);
}

}  // namespace
}  // namespace rbc
