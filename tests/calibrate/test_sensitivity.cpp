// SPDX-License-Identifier: GPL-3.0-or-later
// Parameter sensitivities of the continuum stretch (calibrate/sensitivity.hpp) against central
// differences of the forward model itself, the log-likelihood gradient against central
// differences of the log-likelihood, the identifiability report's Fisher information against
// J'J from central differences (and sigma-scale's closed form), and `rbc infer`'s report.
#include <gtest/gtest.h>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include <Eigen/LU>
#include "app/cli_run.hpp"
#include "calibrate/forward_model.hpp"
#include "calibrate/infer.hpp"
#include "calibrate/sensitivity.hpp"
#include "continuum/continuum_model.hpp"
#include "core/geometry.hpp"
#include "discrete/network_hessian.hpp"
#include "discrete/stretch.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

/// A small model (500 elements, 252 vertices) solved tightly, so that central differences of
/// its diameters are accurate to ~1e-8 um at the steps used.
ForwardOptions tight_options(std::vector<double> forces) {
  ForwardOptions o;
  o.method = parse_method("continuum:2:500");
  o.forces_pN = std::move(forces);
  o.newton.force_tolerance_pN = 1e-8;
  o.newton.constraint_tolerance = 1e-12;
  return o;
}

double& value_of(ForwardParameters& p, Parameter q) {
  switch (q) {
    case Parameter::persistence:
      return p.persistence_nm;
    case Parameter::lmax:
      return p.lmax_nm;
    case Parameter::kappa:
      return p.kappa_J;
    default:
      return p.contact_fraction;
  }
}

/// Central-difference derivative of every diameter (axial then transverse per force) in q at
/// relative step h, from runs warm-started at the centre's equilibria.
std::vector<double> fd_diameters(const ForwardModel& model, const ForwardParameters& p,
                                 const WarmState& warm, Parameter q, double rel) {
  ForwardParameters a = p, b = p;
  const double h = rel * value_of(a, q);
  value_of(a, q) += h;
  value_of(b, q) -= h;
  const ForwardRun ra = model.run(a, warm), rb = model.run(b, warm);
  EXPECT_TRUE(ra.converged && rb.converged);
  std::vector<double> out;
  for (size_t k = 0; k < ra.diameters.axial_um.size(); ++k) {
    out.push_back((ra.diameters.axial_um[k] - rb.diameters.axial_um[k]) / (2 * h));
    out.push_back((ra.diameters.transverse_um[k] - rb.diameters.transverse_um[k]) / (2 * h));
  }
  return out;
}

struct Check {
  std::string what;
  double exact = 0, err_h = 0, err_h2 = 0;
};

/// The implicit-function derivative against central differences at steps h and h/2: the
/// error must fall as h^2 (order in [1.5, 2.5]) where it is above the solver's noise, and be
/// small at h/2 either way.
void expect_second_order(const std::vector<Check>& checks, double noise) {
  for (const Check& c : checks) {
    SCOPED_TRACE(c.what);
    EXPECT_LT(c.err_h2, noise + 2e-3 * std::abs(c.exact))
        << "exact " << c.exact << ", errors " << c.err_h << " " << c.err_h2;
    if (c.err_h > 20 * noise) {
      const double order = std::log2(c.err_h / c.err_h2);
      EXPECT_GT(order, 1.5) << "exact " << c.exact << ", errors " << c.err_h << " " << c.err_h2;
      EXPECT_LT(order, 2.5) << "exact " << c.exact << ", errors " << c.err_h << " " << c.err_h2;
    }
  }
}

/// On the mirror-symmetric subspace (the forward model's default) and in full.
class SensitivityPaths : public ::testing::TestWithParam<Symmetry> {};

TEST_P(SensitivityPaths, DiametersMatchCentralDifferencesOfTheForwardModelToSecondOrder) {
  ForwardOptions o = tight_options({25, 80});
  o.newton.symmetry = GetParam();
  const ForwardModel model(o);
  const StretchSensitivity sens(o);
  ForwardParameters p;  // paper values
  const ForwardRun run = model.run(p);
  ASSERT_TRUE(run.converged);
  const std::vector<Parameter> wrt = {Parameter::persistence, Parameter::lmax, Parameter::kappa,
                                      Parameter::contact_fraction};
  const StretchSensitivities s = sens.compute(p, o.forces_pN, run.state, wrt);
  ASSERT_TRUE(s.converged());
  ASSERT_EQ(s.forces.size(), 2u);
  for (size_t k = 0; k < s.forces.size(); ++k) {
    // The diameters at the extremal vertices are the forward model's.
    EXPECT_NEAR(s.forces[k].axial_um, run.diameters.axial_um[k], 1e-12);
    EXPECT_NEAR(s.forces[k].transverse_um, run.diameters.transverse_um[k], 1e-12);
    EXPECT_LT(s.forces[k].residual_pN, 1e-7);
    EXPECT_EQ(s.forces[k].reduced, GetParam() == Symmetry::mirror);
  }
  std::vector<Check> checks;
  int nontrivial = 0;
  for (size_t j = 0; j < wrt.size(); ++j) {
    // The contact fraction's patch weights are piecewise linear (a vertex entering the patch
    // is a kink): a smaller step keeps both sides of the difference on one piece.
    const double rel = wrt[j] == Parameter::contact_fraction ? 2e-3 : 2e-2;
    const std::vector<double> f1 = fd_diameters(model, p, run.state, wrt[j], rel);
    const std::vector<double> f2 = fd_diameters(model, p, run.state, wrt[j], rel / 2);
    for (size_t k = 0; k < s.forces.size(); ++k)
      for (int t = 0; t < 2; ++t) {
        const double exact = t == 0 ? s.forces[k].d_axial[j] : s.forces[k].d_transverse[j];
        Check c;
        c.what = to_string(wrt[j]) + (t == 0 ? " D_A at " : " D_T at ") +
                 std::to_string(o.forces_pN[k]) + " pN";
        // Errors as diameter changes over the step (um), comparable across parameters.
        const double h = rel * value_of(p, wrt[j]);
        c.exact = exact * h;
        c.err_h = std::abs(f1[2 * k + t] - exact) * h;
        c.err_h2 = std::abs(f2[2 * k + t] - exact) * h;
        if (std::abs(c.exact) > 1e-3) ++nontrivial;
        std::cout << c.what << ": exact " << exact
                  << " um per unit, FD errors (as um over the step " << h << ") " << c.err_h << ", "
                  << c.err_h2 << "\n";
        checks.push_back(c);
      }
  }
  EXPECT_GE(nontrivial, 8);  // the parameters do move the diameters
  expect_second_order(checks, 1e-7);
}

INSTANTIATE_TEST_SUITE_P(Sensitivity, SensitivityPaths,
                         ::testing::Values(Symmetry::mirror, Symmetry::none),
                         [](const auto& info) { return to_string(info.param); });

/// Newton's method on the constrained equilibrium of a network (grad E + C lambda = 0,
/// A = A0, V = V0, rigid modes pinned), dense: polishes a stretch solve to round-off. The root
/// is defined by the gradient alone, and the test requires the residual to reach 1e-10 pN, so a
/// wrong Hessian would show as a polish that does not converge, not as a wrong root.
void polish_equilibrium(const Network& net, double force_pN, Positions& x) {
  std::vector<NetworkTerm> terms;
  for (const NetworkTerm& t : model_terms(net))
    if (t.kind != TermKind::area_volume) terms.push_back(t);
  NetworkHessianOptions ho;
  ho.shift_fraction = 0;
  ho.project = false;
  ho.hinge_curvature = true;
  NetworkHessian hessian(net, ho);
  const int n = net.topo.num_vertices, m = 3 * n + 6;
  double residual = 1;
  for (int it = 0; it < 20 && residual > 1e-10; ++it) {
    LoadState load;
    load.force_pN = force_pN;
    Positions g(3, n);
    EnergyBreakdown parts;
    ASSERT_TRUE(std::isfinite(sum_network_terms(terms, net, x, load, &g, &parts)));
    const ConstraintValues cv = evaluate_constraints(x, net.topo);
    Eigen::MatrixXd c(3 * n, 2);
    c.col(0) = Eigen::Map<const Eigen::VectorXd>(cv.grad_area.data(), 3 * n);
    c.col(1) = Eigen::Map<const Eigen::VectorXd>(cv.grad_volume.data(), 3 * n);
    const Eigen::VectorXd gv = Eigen::Map<const Eigen::VectorXd>(g.data(), 3 * n);
    const Eigen::Vector2d l = (c.transpose() * c).ldlt().solve(-c.transpose() * gv);
    const Eigen::VectorXd r = gv + c * l;
    residual = 0;
    for (int i = 0; i < n; ++i) residual = std::max(residual, r.segment<3>(3 * i).norm());
    const Eigen::SparseMatrix<double> hs =
        hessian.assemble_exact(x, ConstraintCurvature{l(0), l(1)}).selfadjointView<Eigen::Lower>();
    const Eigen::MatrixXd h(hs);
    Eigen::MatrixXd k = Eigen::MatrixXd::Zero(m, m);
    k.topLeftCorner(3 * n, 3 * n) = h;
    k.block(0, 3 * n, 3 * n, 2) = c;
    k.block(3 * n, 0, 2, 3 * n) = c.transpose();
    const Eigen::Vector3d centroid = x.rowwise().mean();
    for (int i = 0; i < n; ++i) {  // translations and the turn about x
      for (int a = 0; a < 3; ++a) k(3 * i + a, 3 * n + 2 + a) = k(3 * n + 2 + a, 3 * i + a) = 1;
      k(3 * i + 1, 3 * n + 5) = k(3 * n + 5, 3 * i + 1) = -(x(2, i) - centroid(2));
      k(3 * i + 2, 3 * n + 5) = k(3 * n + 5, 3 * i + 2) = x(1, i) - centroid(1);
    }
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(m);
    rhs.head(3 * n) = -r;
    rhs(3 * n) = -(cv.area_um2 - net.area0_um2);
    rhs(3 * n + 1) = -(cv.volume_um3 - net.volume0_um3);
    const Eigen::VectorXd dx = k.partialPivLu().solve(rhs);
    Eigen::Map<Eigen::VectorXd>(x.data(), 3 * n) += dx.head(3 * n);
  }
  EXPECT_LE(residual, 1e-10) << "Newton polish at " << force_pN << " pN";
}

/// The network's equilibria at `forces` for parameters p: the discrete stretch (L-BFGS with the
/// augmented Lagrangian) from `start` (per force 3N positions and two multipliers) or by
/// continuation from the rest shape, then polished by Newton (above).
WarmState tight_network_state(const Network& base, const ForwardParameters& p,
                              const std::vector<double>& forces, const WarmState& start) {
  Network net = base;
  apply_forward_parameters(net, p);
  const int n = net.topo.num_vertices, per = 3 * n + 2;
  WarmState out(forces.size() * per);
  Positions x = net.rest;
  ConstraintMultipliers l;
  for (size_t k = 0; k < forces.size(); ++k) {
    if (!start.empty()) {
      x = Eigen::Map<const Positions>(start.data() + k * per, 3, n);
      l = {start[k * per + 3 * n], start[k * per + 3 * n + 1]};
    }
    const StretchPoint pt = solve_equilibrium(net, forces[k], x, l, StretchOptions{});
    EXPECT_TRUE(pt.converged) << forces[k] << " pN: " << to_string(pt.status);
    polish_equilibrium(net, forces[k], x);
    Eigen::Map<Positions>(out.data() + k * per, 3, n) = x;
    out[k * per + 3 * n] = l.area_pN_per_um;
    out[k * per + 3 * n + 1] = l.volume_pN_per_um2;
  }
  return out;
}

TEST(Sensitivity, NetworkDiametersMatchCentralDifferencesOfTheStretchToSecondOrder) {
  ForwardOptions o;
  o.method = parse_method("discrete:100");
  o.forces_pN = {25, 80};
  const StretchSensitivity sens(o);
  const Network base = make_discrete_network(o.method.resolution);
  ASSERT_EQ(sens.vertices(), base.topo.num_vertices);
  const int n = base.topo.num_vertices, per = 3 * n + 2;
  ForwardParameters p;  // paper values
  const WarmState centre = tight_network_state(base, p, o.forces_pN, {});
  const std::vector<Parameter> wrt = {Parameter::persistence, Parameter::lmax, Parameter::kappa,
                                      Parameter::contact_fraction};
  const StretchSensitivities s = sens.compute(p, o.forces_pN, centre, wrt);
  ASSERT_TRUE(s.converged());
  for (size_t k = 0; k < s.forces.size(); ++k) {
    const Diameters d =
        measure_diameters(Eigen::Map<const Positions>(centre.data() + k * per, 3, n));
    EXPECT_NEAR(s.forces[k].axial_um, d.axial_um, 1e-12);
    EXPECT_NEAR(s.forces[k].transverse_um, d.transverse_um, 1e-12);
    EXPECT_LT(s.forces[k].residual_pN, 1e-7);
    EXPECT_FALSE(s.forces[k].reduced);
  }
  const auto diameters = [&](const ForwardParameters& q) {
    const WarmState st = tight_network_state(base, q, o.forces_pN, centre);
    std::vector<double> out;
    for (size_t k = 0; k < o.forces_pN.size(); ++k) {
      const Diameters d = measure_diameters(Eigen::Map<const Positions>(st.data() + k * per, 3, n));
      out.push_back(d.axial_um);
      out.push_back(d.transverse_um);
    }
    return out;
  };
  const auto fd = [&](Parameter q, double rel) {
    ForwardParameters a = p, b = p;
    const double h = rel * value_of(a, q);
    value_of(a, q) += h;
    value_of(b, q) -= h;
    const std::vector<double> da = diameters(a), db = diameters(b);
    std::vector<double> out;
    for (size_t i = 0; i < da.size(); ++i) out.push_back((da[i] - db[i]) / (2 * h));
    return out;
  };
  std::vector<Check> checks;
  int nontrivial = 0;
  for (size_t j = 0; j < wrt.size(); ++j) {
    // Steps of 0.4 % (0.2 % for the patch's piecewise-linear weights): the network's diameters
    // are more curved in the parameters than the continuum's at 25 pN.
    const double rel = wrt[j] == Parameter::contact_fraction ? 2e-3 : 4e-3;
    const std::vector<double> f1 = fd(wrt[j], rel), f2 = fd(wrt[j], rel / 2);
    for (size_t k = 0; k < s.forces.size(); ++k)
      for (int t = 0; t < 2; ++t) {
        const double exact = t == 0 ? s.forces[k].d_axial[j] : s.forces[k].d_transverse[j];
        const double h = rel * value_of(p, wrt[j]);
        Check c;
        c.what = to_string(wrt[j]) + (t == 0 ? " D_A at " : " D_T at ") +
                 std::to_string(o.forces_pN[k]) + " pN";
        c.exact = exact * h;
        c.err_h = std::abs(f1[2 * k + t] - exact) * h;
        c.err_h2 = std::abs(f2[2 * k + t] - exact) * h;
        if (std::abs(c.exact) > 1e-3) ++nontrivial;
        std::cout << c.what << ": exact " << exact
                  << " um per unit, FD errors (as um over the step " << h << ") " << c.err_h << ", "
                  << c.err_h2 << "\n";
        checks.push_back(c);
      }
  }
  EXPECT_GE(nontrivial, 6);
  expect_second_order(checks, 1e-8);
}

TEST(Sensitivity, RefusesAStateThatDoesNotFit) {
  const ForwardOptions o = tight_options({10});
  const StretchSensitivity s(o);
  EXPECT_THROW(
      s.compute(ForwardParameters{}, o.forces_pN, WarmState(7, 0.0), {Parameter::persistence}),
      std::invalid_argument);
}

/// A data set of three forces near the model's curve (written under build/test_output).
std::string write_data(const std::string& name) {
  const auto dir = testing::fresh_output_dir(name);
  const std::string path = (dir / "data.csv").string();
  std::ofstream f(path);
  f << "# name: sensitivity test data\n"
       "force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n"
       "0.0,7.8,0.3,7.8,0.3\n"
       "30.0,10.3,0.4,6.4,0.35\n"
       "90.0,12.6,0.5,5.2,0.4\n";
  return path;
}

InferOptions small_problem(const std::string& data, std::vector<Parameter> params) {
  InferOptions o;
  o.data_file = data;
  o.method = parse_method("continuum:2:500");
  o.parameters = std::move(params);
  o.force_tolerance_pN = 1e-8;
  return o;
}

TEST(Sensitivity, LogLikelihoodGradientMatchesCentralDifferences) {
  const InferenceProblem problem(
      small_problem(write_data("sensitivity_gradient"),
                    {Parameter::persistence, Parameter::lmax, Parameter::sigma_scale}));
  const StretchSensitivity sens(problem.forward().options());
  const std::vector<double> theta = {9.0, 220.0, 1.3};
  const LikelihoodGradient g = log_likelihood_and_gradient(problem, sens, theta);
  ASSERT_FALSE(g.failed);
  ASSERT_EQ(g.gradient.size(), 3u);
  // log L equals the sampler's.
  const LikelihoodValue v = problem.likelihood().evaluate(theta, {}, nullptr);
  EXPECT_NEAR(g.log_likelihood, v.log_likelihood, 1e-6);
  std::vector<Check> checks;
  for (int k = 0; k < 3; ++k) {
    const auto fd = [&](double rel) {
      std::vector<double> a = theta, b = theta;
      const double h = rel * theta[k];
      a[k] += h;
      b[k] -= h;
      const double la = problem.likelihood().evaluate(a, g.state, nullptr).log_likelihood;
      const double lb = problem.likelihood().evaluate(b, g.state, nullptr).log_likelihood;
      return (la - lb) / (2 * h);
    };
    const double rel = 2e-2;
    const double h = rel * theta[k];
    Check c;
    c.what = "d log L / d " + to_string(problem.options().parameters[k]);
    c.exact = g.gradient[k] * h;
    c.err_h = std::abs(fd(rel) - g.gradient[k]) * h;
    c.err_h2 = std::abs(fd(rel / 2) - g.gradient[k]) * h;
    std::cout << c.what << ": " << g.gradient[k] << ", FD errors (as log L over the step) "
              << c.err_h << ", " << c.err_h2 << "\n";
    EXPECT_GT(std::abs(c.exact), 1e-2) << c.what;  // not a trivially flat direction
    checks.push_back(c);
  }
  expect_second_order(checks, 1e-6);
}

TEST(Sensitivity, IdentifiabilityFisherIsTheGaussNewtonMatrixOfFiniteDifferences) {
  // The Fisher information in log parameters against J'J with J from central differences of
  // the forward model; sigma-scale's information is 2 per Gaussian term exactly (5 terms: two
  // per force, one at 0 pN) and uncoupled; combinations ranked, sd = 1/sqrt(eigenvalue).
  const InferenceProblem problem(
      small_problem(write_data("sensitivity_identifiability"),
                    {Parameter::persistence, Parameter::lmax, Parameter::sigma_scale}));
  const std::vector<double> theta = {9.0, 220.0, 1.0};
  const IdentifiabilityReport r = identifiability(problem, theta, {20.0, 150.0});
  ASSERT_EQ(r.status, "ok");
  ASSERT_EQ(r.combinations.size(), 3u);
  EXPECT_NEAR(r.fisher_log(2, 2), 2.0 * 5, 1e-12);
  {
    const DiameterData& d = problem.data();
    const ForwardRun centre = problem.forward().run(problem.physical(theta));
    ASSERT_TRUE(centre.converged);
    Eigen::MatrixXd j(5, 2);
    for (int k = 0; k < 2; ++k) {
      std::vector<double> a = theta, b = theta;
      const double h = 1e-2;  // in log theta_k
      a[k] *= std::exp(h);
      b[k] *= std::exp(-h);
      const ForwardRun ra = problem.forward().run(problem.physical(a), centre.state);
      const ForwardRun rb = problem.forward().run(problem.physical(b), centre.state);
      ASSERT_TRUE(ra.converged && rb.converged);
      int row = 0;
      for (int i = 0; i < d.size(); ++i) {
        j(row++, k) =
            (ra.diameters.axial_um[i] - rb.diameters.axial_um[i]) / (2 * h) / d.axial_sigma_um[i];
        if (d.transverse_used[i])
          j(row++, k) = (ra.diameters.transverse_um[i] - rb.diameters.transverse_um[i]) / (2 * h) /
                        d.transverse_sigma_um[i];
      }
    }
    const Eigen::MatrixXd f = j.transpose() * j;
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b)
        EXPECT_NEAR(r.fisher_log(a, b), f(a, b), 1e-3 * f.norm()) << a << " " << b;
  }
  EXPECT_EQ(r.fisher_log(0, 2), 0.0);
  // Eigenvalues descending, sd = 1/sqrt(eigenvalue).
  for (size_t e = 0; e < 3; ++e)
    EXPECT_NEAR(r.combinations[e].sd_log, 1 / std::sqrt(r.combinations[e].eigenvalue), 1e-12);
  EXPECT_GE(r.combinations[0].eigenvalue, r.combinations[1].eigenvalue);
  EXPECT_GE(r.combinations[1].eigenvalue, r.combinations[2].eigenvalue);
  // The sigma-scale's combination is the pure log sigma-scale axis.
  bool found = false;
  for (const auto& c : r.combinations)
    if (std::abs(std::abs(c.coefficients[2]) - 1) < 1e-9) {
      found = true;
      EXPECT_NEAR(c.sd_log, 1 / std::sqrt(10.0), 1e-9);
    }
  EXPECT_TRUE(found);
  // Candidate gains: positive and ranked.
  ASSERT_EQ(r.candidates.size(), 2u);
  EXPECT_GT(r.candidates[1].gain_nats, 0);
  EXPECT_GE(r.candidates[0].gain_nats, r.candidates[1].gain_nats);
  EXPECT_GT(r.mu_relative_sd, 0);
  EXPECT_FALSE(r.lines().empty());
  for (const auto& l : r.lines()) std::cout << l << "\n";
}

// `rbc infer --out DIR` writes the report at the posterior median, prints it, lists it in
// run.json, and refuses a bad --candidate-forces before any work.
TEST(Sensitivity, InferWritesTheIdentifiabilityReportAtThePosteriorMedian) {
  const std::string data = write_data("sensitivity_cli_data");
  const auto dir = testing::fresh_output_dir("sensitivity_cli");
  const std::string common =
      "infer -q --method continuum:2:200 --sampler tmcmc --samples 20 --chain-length 1 --seed 2 "
      "--params persistence,lmax,sigma-scale --data-file " +
      data + " --out " + (dir / "run").string();
  for (const std::string bad : {"10,x", "10,500", "-1"}) {
    const testing::CliRun r = testing::run_rbc(common + " --candidate-forces " + bad);
    EXPECT_EQ(r.exit_code, 2) << r.all();
    EXPECT_NE(r.err.find("rbc: error: --candidate-forces " + bad), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "run" / "summary.json"));
  }
  const testing::CliRun r = testing::run_rbc(common + " --candidate-forces 10,200");
  ASSERT_EQ(r.exit_code, 0) << r.all();
  EXPECT_NE(r.out.find("identifiability at the posterior median"), std::string::npos) << r.out;
  const auto read = [&](const char* name) {
    std::ifstream f(dir / "run" / name);
    return nlohmann::json::parse(f);
  };
  const nlohmann::json id = read("identifiability.json"), summary = read("summary.json");
  EXPECT_EQ(id["status"], "ok");
  for (const char* p : {"persistence", "lmax", "sigma-scale"})
    EXPECT_EQ(id["at"][p].get<double>(), summary["parameters"][p]["q50"].get<double>()) << p;
  ASSERT_EQ(id["combinations"].size(), 3u);
  for (size_t e = 1; e < 3; ++e)  // best determined first
    EXPECT_GE(id["combinations"][e - 1]["eigenvalue"].get<double>(),
              id["combinations"][e]["eigenvalue"].get<double>());
  ASSERT_EQ(id["candidate_forces"].size(), 2u);
  EXPECT_GE(id["candidate_forces"][0]["gain_nats"].get<double>(),
            id["candidate_forces"][1]["gain_nats"].get<double>());
  const nlohmann::json run = read("run.json");
  EXPECT_NE(std::find(run["outputs"].begin(), run["outputs"].end(), "identifiability.json"),
            run["outputs"].end());
}

}  // namespace
}  // namespace rbc
