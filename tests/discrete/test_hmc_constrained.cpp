// SPDX-License-Identifier: GPL-3.0-or-later
// Constrained HMC (discrete/hmc_constrained.hpp) samples the stiff-penalty law
// exp(-U) delta(xi) dx on its manifold, whatever the mass matrix: a point on the unit sphere
// (one constraint) and on a great circle (two constraints) under a linear field, whose laws are
// known in closed form, with a strongly anisotropic mass so that the Fixman term matters (without
// it the law would carry the factor sqrt(det J M^-1 J')); chi-square tests that can fail.
#include <gsl/gsl_cdf.h>
#include <gsl/gsl_rng.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <functional>
#include <memory>
#include <numbers>
#include <vector>

#include "chi_square.hpp"
#include "discrete/hmc_constrained.hpp"

namespace rbc {
namespace {

struct ConstrainedRng {
  std::unique_ptr<gsl_rng, void (*)(gsl_rng*)> r{gsl_rng_alloc(gsl_rng_mt19937), gsl_rng_free};
  explicit ConstrainedRng(unsigned long seed) { gsl_rng_set(r.get(), seed); }
  gsl_rng* get() const { return r.get(); }
};

/// U(x) = a z (dimensionless).
HmcPotential linear_field(double a) {
  return [a](const Eigen::VectorXd& x, Eigen::VectorXd& g) {
    g = Eigen::Vector3d(0, 0, a);
    return a * x(2);
  };
}

/// xi_0 = |x|^2 - 1 and, with `plane`, xi_1 = x . (1, 1, 1) / sqrt 3.
HmcConstraints sphere(bool plane) {
  HmcConstraints c;
  const int m = plane ? 2 : 1;
  const Eigen::Vector3d normal = Eigen::Vector3d::Ones() / std::sqrt(3.0);
  c.evaluate = [m, normal](const Eigen::VectorXd& x, Eigen::VectorXd& v, Eigen::MatrixXd& jt) {
    v.resize(m);
    jt.resize(3, m);
    v(0) = x.squaredNorm() - 1.0;
    jt.col(0) = 2.0 * x;
    if (m == 2) {
      v(1) = normal.dot(x);
      jt.col(1) = normal;
    }
  };
  c.hessian_times = [](const Eigen::VectorXd&, int a, const Eigen::VectorXd& w) {
    return a == 0 ? Eigen::VectorXd(2.0 * w) : Eigen::VectorXd(Eigen::VectorXd::Zero(3));
  };
  c.tolerance = Eigen::VectorXd::Constant(m, 1e-12);
  return c;
}

/// Bin probabilities of a density on [lo, hi] by the midpoint rule (2,000 points a bin).
std::vector<double> density_bin_probabilities(const std::function<double(double)>& density,
                                              double lo, double hi, int bins) {
  std::vector<double> p(std::size_t(bins), 0.0);
  const int n = 2000;
  double total = 0;
  for (int b = 0; b < bins; ++b) {
    const double w = (hi - lo) / bins;
    for (int i = 0; i < n; ++i) p[std::size_t(b)] += density(lo + w * (b + (i + 0.5) / n));
    total += p[std::size_t(b)];
  }
  for (double& q : p) q /= total;
  return p;
}

struct ConstrainedHistogram {
  std::vector<long> count;
  double acceptance = 0;
  double largest_violation = 0;  ///< max |xi_a| over the recorded states
  int failed = 0;                ///< steps whose solve or reverse check failed
};

/// Runs the chain from `start` and bins coordinate(x) over [lo, hi].
ConstrainedHistogram sample_constrained(
    const HmcPotential& u, const HmcConstraints& c, const MassMatrix& mass,
    const Eigen::Vector3d& start, const std::function<double(const Eigen::VectorXd&)>& coordinate,
    double lo, double hi, int bins, long samples, int thin, double step) {
  ConstrainedRng rng(11);
  HmcOptions o;
  o.step = step;
  HmcConstrainedState s = hmc_constrained_state(u, c, mass, start);
  ConstrainedHistogram h;
  h.count.assign(std::size_t(bins), 0);
  long accepted = 0, transitions = 0;
  for (long i = -200; i < samples; ++i) {  // 200 x thin transitions of warm-up
    for (int t = 0; t < thin; ++t) {
      const HmcConstrainedTransition r = hmc_constrained_transition(
          u, c, mass, s, o.step, hmc_step_count(o, o.step, rng.get()), rng.get());
      accepted += r.transition.accepted;
      h.failed += r.failed_solves + r.failed_reverse_checks;
      ++transitions;
    }
    if (i < 0) continue;
    Eigen::VectorXd v;
    Eigen::MatrixXd jt;
    c.evaluate(s.x, v, jt);
    h.largest_violation = std::max(h.largest_violation, v.cwiseAbs().maxCoeff());
    const double q = (coordinate(s.x) - lo) / (hi - lo);
    ++h.count[std::size_t(std::clamp(int(q * bins), 0, bins - 1))];
  }
  h.acceptance = double(accepted) / double(transitions);
  return h;
}

// The mass: light in x, 25 times heavier along z, coupled; G_M = J M^-1 J' then varies by a
// factor of about 20 over the sphere.
DenseMassMatrix anisotropic_mass() {
  Eigen::Matrix3d m;
  m << 1.0, 0.3, 0.0, 0.3, 2.0, 0.5, 0.0, 0.5, 25.0;
  return DenseMassMatrix(m);
}

// One constraint: on the unit sphere the Euclidean area is uniform in z (Archimedes) and
// |grad xi| = 2 is constant, so exp(-a z) delta(xi) dx has z-density ~ exp(-a z) on [-1, 1].
TEST(HmcConstrained, SphereHistogramIsTheStiffPenaltyLawWhateverTheMass) {
  const double a = 1.5;
  const DenseMassMatrix mass = anisotropic_mass();
  const HmcConstraints c = sphere(false);
  const int bins = 20;
  const long samples = 20000;
  // Thinned by 10 transitions: at 3 the counts of 100,000 samples still fail (chi-square 34 on
  // 19 degrees of freedom, the samples correlated), at 10 they pass (19 on 19).
  const ConstrainedHistogram h = sample_constrained(
      linear_field(a), c, mass, Eigen::Vector3d(1, 0, 0),
      [](const Eigen::VectorXd& x) { return x(2); }, -1.0, 1.0, bins, samples, 10, 0.25);
  EXPECT_GT(h.acceptance, 0.6);
  EXPECT_LE(h.largest_violation, 1e-12);
  int dof = 0;
  const auto law = [a](double z) { return std::exp(-a * z); };
  const double chi2 =
      testing::chi_square(h.count, density_bin_probabilities(law, -1, 1, bins), samples, &dof);
  ASSERT_GT(dof, 10);
  EXPECT_LT(chi2, gsl_cdf_chisq_Qinv(1e-3, dof)) << "dof " << dof;
  // Power: the law without the Fixman term, exp(-a z) sqrt(n' M^-1 n) (n = x on the sphere,
  // averaged over the azimuth), fails on the same counts.
  const Eigen::Matrix3d minv =
      Eigen::Matrix3d(Eigen::Matrix3d{{1.0, 0.3, 0.0}, {0.3, 2.0, 0.5}, {0.0, 0.5, 25.0}})
          .inverse();
  const auto without_fixman = [a, &minv](double z) {
    double s = 0;
    const int n = 64;
    for (int k = 0; k < n; ++k) {
      const double phi = 2.0 * std::numbers::pi * (k + 0.5) / n, r = std::sqrt(1 - z * z);
      const Eigen::Vector3d x(r * std::cos(phi), r * std::sin(phi), z);
      s += std::sqrt(x.dot(minv * x));
    }
    return std::exp(-a * z) * s / n;
  };
  int dof_wrong = 0;
  const double chi2_wrong = testing::chi_square(
      h.count, density_bin_probabilities(without_fixman, -1, 1, bins), samples, &dof_wrong);
  EXPECT_GT(chi2_wrong, gsl_cdf_chisq_Qinv(1e-3, dof_wrong));
}

// Two constraints: the great circle x . (1,1,1) = 0 of the unit sphere. J J' = diag(4, 1) there
// is constant, so the law is exp(-a z) d(theta) in the circle's angle theta, measured from the
// circle's highest point: z = sqrt(2/3) cos theta.
TEST(HmcConstrained, GreatCircleHistogramIsTheStiffPenaltyLawWithTwoConstraints) {
  const double a = 2.0;
  const DenseMassMatrix mass = anisotropic_mass();
  const HmcConstraints c = sphere(true);
  // Orthonormal basis of the plane: e1 towards +z, e2 = n x e1.
  const Eigen::Vector3d n = Eigen::Vector3d::Ones() / std::sqrt(3.0);
  const Eigen::Vector3d e1 = (Eigen::Vector3d(0, 0, 1) - n * n(2)).normalized();
  const Eigen::Vector3d e2 = n.cross(e1);
  const double pi = std::numbers::pi;
  const auto theta = [e1, e2](const Eigen::VectorXd& x) {
    return std::atan2(e2.dot(x.head<3>()), e1.dot(x.head<3>()));
  };
  const int bins = 24;
  const long samples = 20000;
  const ConstrainedHistogram h =
      sample_constrained(linear_field(a), c, mass, e2, theta, -pi, pi, bins, samples, 10, 0.25);
  EXPECT_GT(h.acceptance, 0.6);
  EXPECT_LE(h.largest_violation, 1e-12);
  const double ez = e1(2);  // z = ez cos(theta)
  int dof = 0;
  const auto law = [a, ez](double t) { return std::exp(-a * ez * std::cos(t)); };
  const double chi2 =
      testing::chi_square(h.count, density_bin_probabilities(law, -pi, pi, bins), samples, &dof);
  ASSERT_GT(dof, 10);
  EXPECT_LT(chi2, gsl_cdf_chisq_Qinv(1e-3, dof)) << "dof " << dof;
  // Power: a 10 % weaker field fails.
  int dof_wrong = 0;
  const auto weaker = [a, ez](double t) { return std::exp(-0.9 * a * ez * std::cos(t)); };
  const double chi2_wrong = testing::chi_square(
      h.count, density_bin_probabilities(weaker, -pi, pi, bins), samples, &dof_wrong);
  EXPECT_GT(chi2_wrong, gsl_cdf_chisq_Qinv(1e-3, dof_wrong));
}

// Projection: a point off the sphere is moved onto it along M^-1 J'; a start off the manifold
// is refused.
TEST(HmcConstrained, ProjectionReachesTheManifoldAndAnOffManifoldStartIsRefused) {
  const DenseMassMatrix mass = anisotropic_mass();
  const HmcConstraints c = sphere(true);
  const Eigen::Vector3d off(0.9, -0.2, -0.5);
  const Eigen::VectorXd on = hmc_project_onto_constraints(c, mass, off);
  Eigen::VectorXd v;
  Eigen::MatrixXd jt;
  c.evaluate(on, v, jt);
  EXPECT_LE(v.cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_THROW(hmc_constrained_state(linear_field(1.0), c, mass, off), std::runtime_error);
}

}  // namespace
}  // namespace rbc
