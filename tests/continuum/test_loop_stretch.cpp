// SPDX-License-Identifier: GPL-3.0-or-later
// The continuum stretch on the Loop element (continuum/loop_terms.hpp, continuum/loop_stretch.hpp):
// each term's derivatives against finite differences, the rest state stress-free, the limit
// surface's area and volume against the sphere's closed forms, the load's total force exact, and
// the stretch against the linear element on a fine mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <string>

#include "continuum/adapted_mesh.hpp"
#include "continuum/continuum_stretch.hpp"
#include "continuum/hessian_check.hpp"
#include "continuum/loop_stretch.hpp"
#include "continuum/p2_law.hpp"
#include "fixtures.hpp"
#include "homogenise/invariant_laws.hpp"

namespace rbc {
namespace {

std::array<Vec3, 3> loop_stretch_test_vectors(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  return {Vec3(0.5 + u(rng), u(rng), 1.0 + u(rng)), Vec3(1.0 + u(rng), u(rng), u(rng)),
          Vec3(u(rng), 0.9 + u(rng), u(rng))};
}

// FD checks of a density f(z) with analytic gradient and Hessian (z of size n).
void check_density(
    const std::function<double(const Eigen::VectorXd&, Eigen::VectorXd*, Eigen::MatrixXd*)>& f,
    const Eigen::VectorXd& z, const char* what) {
  Eigen::VectorXd g;
  Eigen::MatrixXd h;
  f(z, &g, &h);
  auto value = [&](const Eigen::VectorXd& y) { return f(y, nullptr, nullptr); };
  const auto [eh, eh2] = testing::fd_directional_errors(value, z, g, 1e-3, 4);
  EXPECT_GT(eh / eh2, 3.0) << what;
  EXPECT_LT(testing::fd_gradient_error(value, z, g, 6e-6, static_cast<int>(z.size()), 4),
            1e-7 * (1 + g.norm()))
      << what;
  const auto grad = [&](const Eigen::VectorXd& y) {
    Eigen::VectorXd gy;
    f(y, &gy, nullptr);
    return gy;
  };
  const auto hv = [&](const Eigen::VectorXd& d) { return Eigen::VectorXd(h * d); };
  testing::expect_hessian_ok(testing::check_hessian_direction(grad, z, hv, 1.0, 6), what);
  EXPECT_LT((h - h.transpose()).cwiseAbs().maxCoeff(), 1e-12 * (1 + h.cwiseAbs().maxCoeff()))
      << what;
}

// A density with fixed-size derivatives (N) as check_density's dynamic-size function.
template <int N, class F>
auto loop_dynamic_density(F f) {
  return [f](const Eigen::VectorXd& z, Eigen::VectorXd* g, Eigen::MatrixXd* h) {
    Eigen::Matrix<double, N, 1> gn;
    Eigen::Matrix<double, N, N> hn;
    const double e = f(z, g != nullptr ? &gn : nullptr, h != nullptr ? &hn : nullptr);
    if (g != nullptr) *g = gn;
    if (h != nullptr) *h = hn;
    return e;
  };
}

TEST(LoopTerms, DensityDerivativesMatchFiniteDifferences) {
  const IsotropicMembraneLaw law = testing::closed_form_p2_law();
  for (unsigned seed : {1u, 2u}) {
    const auto v = loop_stretch_test_vectors(seed);
    const LoopMembraneReference ref =
        make_loop_membrane_reference(v[1] + Vec3(0.05, 0.1, 0.0), v[2] - Vec3(0.1, 0.0, 0.05));
    Eigen::VectorXd z6(6), z9(9);
    z6 << v[1], v[2];
    z9 << v[0], v[1], v[2];
    check_density(loop_dynamic_density<6>([&](const Eigen::VectorXd& z, auto* g, auto* h) {
                    return loop_membrane_density(law, ref, z.head<3>(), z.tail<3>(), g, h);
                  }),
                  z6, "membrane");
    check_density(loop_dynamic_density<6>([&](const Eigen::VectorXd& z, auto* g, auto* h) {
                    return loop_area_density(z.head<3>(), z.tail<3>(), g, h);
                  }),
                  z6, "area");
    check_density(loop_dynamic_density<9>([&](const Eigen::VectorXd& z, auto* g, auto* h) {
                    return loop_volume_density(z.segment<3>(0), z.segment<3>(3), z.segment<3>(6), g,
                                               h);
                  }),
                  z9, "volume");
  }
}

TEST(LoopTerms, MembraneIsStressFreeAtItsReferenceAndRigidMotionInvariant) {
  const IsotropicMembraneLaw law = testing::closed_form_p2_law();
  const auto v = loop_stretch_test_vectors(3);
  const LoopMembraneReference ref = make_loop_membrane_reference(v[1], v[2]);
  Vector6d g;
  EXPECT_NEAR(loop_membrane_density(law, ref, v[1], v[2], &g),
              ref.jacobian_um2 * law.evaluate(0, 0).psi, 1e-12);
  EXPECT_LT(g.norm(), 1e-10);
  const Eigen::Matrix3d r = testing::random_rotation(4);
  const Vec3 a = 1.1 * v[1] + 0.1 * v[2], b = 0.95 * v[2];
  EXPECT_NEAR(loop_membrane_density(law, ref, r * a, r * b), loop_membrane_density(law, ref, a, b),
              1e-12);
  EXPECT_THROW(make_loop_membrane_reference(v[1], 2.0 * v[1]), InvalidParameter);
}

LoopContinuumModel loop_test_model(int elements) {
  const EvansFungShape shape;
  TriMesh m = make_continuum_mesh(elements, shape);
  for (int i = 0; i < m.x.cols(); ++i) m.x.col(i) = evans_fung_project(shape, m.x.col(i));
  return build_loop_continuum_model(m, testing::closed_form_p2_law(), {},
                                    rest_contact_plane(shape, 0.05));
}

TEST(LoopStretch, AreaAndVolumeOfTheInterpolatedSphereConverge) {
  const double r = 2.5;
  std::vector<double> ea, ev;
  for (int freq : {4, 8, 16}) {
    const TriMesh m = testing::sphere_mesh(freq, r);
    LoopContinuumModel model;
    model.topo = m.topo;
    model.quadrature = loop_quadrature(m.topo);
    const ConstraintValues c =
        loop_constraints(model, loop_interpolating_control_points(m.topo, m.x), false);
    ea.push_back(std::abs(c.area_um2 / (4 * units::pi * r * r) - 1));
    ev.push_back(std::abs(c.volume_um3 / (4.0 / 3 * units::pi * r * r * r) - 1));
  }
  std::printf("[ sphere ] limit-surface area errors %.2e %.2e %.2e, volume %.2e %.2e %.2e\n", ea[0],
              ea[1], ea[2], ev[0], ev[1], ev[2]);
  EXPECT_LT(ea[2], 2e-5);
  EXPECT_LT(ev[2], 2e-5);
  EXPECT_GT(std::log(ea[1] / ea[2]) / std::log(2.0), 1.8);
}

TEST(LoopStretch, EachCapCarriesExactlyTheForceAndTheLoadIsMirrorSymmetric) {
  const LoopContinuumModel m = loop_test_model(1000);
  double right = 0, left = 0, other = 0;
  for (int i = 0; i < m.topo.num_vertices; ++i) {
    right += m.load_right(3 * i);
    left += m.load_left(3 * i);
    other += std::abs(m.load_right(3 * i + 1)) + std::abs(m.load_right(3 * i + 2));
  }
  EXPECT_NEAR(right, 1.0, 1e-13);
  EXPECT_NEAR(left, 1.0, 1e-13);
  EXPECT_EQ(other, 0.0);
  EXPECT_GT(m.load_points, 100);
  // A rigid translation does no work: the two caps pull equally and oppositely.
  double work = 0;
  for (int i = 0; i < m.topo.num_vertices; ++i) work += m.load(3 * i);
  EXPECT_NEAR(work, 0.0, 1e-13);
}

TEST(LoopStretch, EnergyGradientAndLagrangianHessianMatchFiniteDifferences) {
  const LoopContinuumModel m = loop_test_model(500);
  Positions x = m.rest;
  testing::perturb(x, 0.02, 8);
  const double force = 60.0, la = 3.0, lv = -2.0;
  const Eigen::Index n = x.cols();
  auto lagrangian = [&](const Eigen::VectorXd& y, Eigen::VectorXd* g) {
    const Eigen::Map<const Positions> xy(y.data(), 3, n);
    Positions ge;
    const double e = loop_continuum_energy(m, xy, force, g ? &ge : nullptr);
    const ConstraintValues c = loop_constraints(m, xy, g != nullptr);
    if (g) *g = flat(ge) + la * flat(c.grad_area) + lv * flat(c.grad_volume);
    return e + la * c.area_um2 + lv * c.volume_um3;
  };
  const Eigen::VectorXd x0 = flat(x);
  Eigen::VectorXd g0;
  lagrangian(x0, &g0);
  auto value = [&](const Eigen::VectorXd& y) { return lagrangian(y, nullptr); };
  const auto [eh, eh2] = testing::fd_directional_errors(value, x0, g0, 1e-3, 2);
  EXPECT_GT(eh / eh2, 3.0);
  EXPECT_LT(testing::fd_gradient_error(value, x0, g0, 1e-5, 30, 2), 1e-6 * (1 + g0.norm()));
  LoopHessianAssembler assembler(m);
  const Eigen::SparseMatrix<double>& h = assembler.assemble(m, x, la, lv);
  const auto grad = [&](const Eigen::VectorXd& y) {
    Eigen::VectorXd g;
    lagrangian(y, &g);
    return g;
  };
  const auto hv = [&](const Eigen::VectorXd& d) {
    return Eigen::VectorXd(h.selfadjointView<Eigen::Lower>() * d);
  };
  testing::expect_hessian_ok(testing::check_hessian_direction(grad, x0, hv, 1.0, 3),
                             "Loop Lagrangian");
}

// The Loop stretch at 88 pN on 1,000 elements against the linear element on 9,680 (full law,
// exact contact load, quadric-fit diameters): the two discretisations of one model agree.
TEST(LoopStretch, AgreesWithTheLinearElementOnAFineMesh) {
  const EvansFungShape shape;
  const IsotropicMembraneLaw law =
      make_membrane_law(WlcParameters{}, StericParameters{}, WlcExpansion::full);
  TriMesh m = make_continuum_mesh(1000, shape);
  for (int i = 0; i < m.x.cols(); ++i) m.x.col(i) = evans_fung_project(shape, m.x.col(i));
  const LoopContinuumModel lm =
      build_loop_continuum_model(m, law, {}, rest_contact_plane(shape, 0.05));
  const auto lp = run_loop_stretch(lm, {88.0});
  ASSERT_EQ(lp[0].status, NewtonStatus::converged);
  const ContinuumModel fine = build_continuum_model(make_continuum_mesh(9680, shape), law, {});
  ContinuumOptions co;
  co.load = ContinuumLoad::exact_contact;
  co.measure = ContinuumMeasure::quadric_fit;
  const auto fp = run_continuum_stretch(fine, {88.0}, co);
  std::printf(
      "88 pN: Loop 1,000 elements D_A %.4f D_T %.4f (%d iterations); linear 9,680: %.4f "
      "%.4f\n",
      lp[0].diameters.axial_um, lp[0].diameters.transverse_um, lp[0].iterations, fp[0].axial_um,
      fp[0].transverse_um);
  EXPECT_NEAR(lp[0].diameters.axial_um / fp[0].axial_um, 1.0, 3e-3);
  EXPECT_NEAR(lp[0].diameters.transverse_um / fp[0].transverse_um, 1.0, 3e-3);
}

// The 13 Mills forces against the spectrin-level reference (data/tradeoff/reference.csv: the
// network at 27,042 vertices, mean over 5 rotations), full law, uniform icospheres with their
// vertices on the Evans-Fung surface, 4 orientations each (RestShapeOptions::rotation_seed 0-3):
// the largest relative error of D_A and D_T over the forces, worst over the orientations. The
// linear element's best rows at these sizes (data/tradeoff/accuracy_cost_refined.csv, the same
// load and a quadric-fitted measure) err 0.575 % (760 triangles), 0.545 % (1,220) and 0.145 %
// (2,288). About 5 minutes (`ctest -L slow -R LoopStretch`).
TEST(SlowReferenceLoopStretch, ErrsAgainstTheSpectrinLevelOverFourOrientations) {
  const EvansFungShape shape;
  const IsotropicMembraneLaw law =
      make_membrane_law(WlcParameters{}, StericParameters{}, WlcExpansion::full);
  std::vector<double> forces, ref_a, ref_t;
  std::ifstream in(std::string(RBC_SOURCE_DIR) + "/data/tradeoff/reference.csv");
  ASSERT_TRUE(in.good());
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#' || line[0] == 'f') continue;
    double v[4];
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf", v, v + 1, v + 2, v + 3), 4);
    forces.push_back(v[0]);
    ref_a.push_back(v[1]);
    ref_t.push_back(v[3]);
  }
  ASSERT_EQ(forces.size(), 13u);
  std::map<int, double> worst;
  for (int el : {500, 1000, 2000})
    for (unsigned seed : {0u, 1u, 2u, 3u}) {
      TriMesh m = make_continuum_mesh(el, seed);
      for (int i = 0; i < m.x.cols(); ++i) m.x.col(i) = evans_fung_project(shape, m.x.col(i));
      const LoopContinuumModel lm =
          build_loop_continuum_model(m, law, {}, rest_contact_plane(shape, 0.05));
      const auto pts = run_loop_stretch(lm, forces);
      double err = 0;
      int iterations = 0;
      for (std::size_t i = 0; i < forces.size(); ++i) {
        ASSERT_EQ(pts[i].status, NewtonStatus::converged) << forces[i] << " pN";
        iterations += pts[i].iterations;
        err = std::max({err, std::abs(pts[i].diameters.axial_um / ref_a[i] - 1),
                        std::abs(pts[i].diameters.transverse_um / ref_t[i] - 1)});
      }
      std::printf(
          "[ Loop ] %4d elements, %4d vertices, orientation %u: worst %.3f %% (%d Newton "
          "iterations)\n",
          el, static_cast<int>(m.x.cols()), seed, 100 * err, iterations);
      worst[el] = std::max(worst[el], err);
    }
  EXPECT_LT(worst[1000], 0.005);
  EXPECT_LT(worst[2000], 0.0015);
}

}  // namespace
}  // namespace rbc
