// SPDX-License-Identifier: GPL-3.0-or-later
// The Canham-Helfrich rest-shape relaxation (continuum/relax.hpp relax_helfrich, behind
// `rbc relax`) against independent truths:
//  - a sphere at its own area and volume is stationary for any H0, with the closed-form
//    Helfrich energy 2 pi kappa (2 - H0 R)^2 (8 pi kappa at H0 = 0, at every radius) and the
//    uniform mean curvature H = C1 + C2 = 2/R at every vertex;
//  - the Evans-Fung shape relaxes to a state where the gradient of the Lagrangian vanishes,
//    with multipliers the test fits itself (least squares), the area and volume recomputed
//    here, and the Helfrich energy below the start;
//  - the in-plane regulariser holding the mesh together stores a small share of the energy and
//    moves the relaxed shape little: halving its weight halves the residual Helfrich force and
//    changes the shape by a small fraction of the relaxation.
#include <gtest/gtest.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>

#include "continuum/relax.hpp"
#include "core/units.hpp"
#include "discrete/bending_energy.hpp"
#include "fixtures.hpp"
#include "p2_law.hpp"

namespace rbc {
namespace {

/// The in-plane regulariser `rbc relax` uses: the p = 2 law scaled by `weight`.
IsotropicMembraneLaw regulariser(double weight) {
  return scaled_law(testing::closed_form_p2_law(), weight);
}

/// grad + lambda_A dA + lambda_V dV with the multipliers that minimise its 2-norm (3 x N, pN):
/// the part of a force field the area and volume constraints cannot balance. Fitted here, so
/// the solver's own multipliers are not the oracle.
Positions constrained_residual(const Positions& grad, const ConstraintValues& c) {
  const Eigen::Index n = grad.size();
  Eigen::MatrixXd C(n, 2);
  C.col(0) = Eigen::Map<const Eigen::VectorXd>(c.grad_area.data(), n);
  C.col(1) = Eigen::Map<const Eigen::VectorXd>(c.grad_volume.data(), n);
  const Eigen::Map<const Eigen::VectorXd> g(grad.data(), n);
  const Eigen::VectorXd r = g + C * C.colPivHouseholderQr().solve(-g);
  return Eigen::Map<const Positions>(r.data(), 3, grad.cols());
}

/// Largest residual force of the full model's Lagrangian (regulariser + Helfrich) at x (pN).
double lagrangian_residual_pN(const ContinuumModel& model, const Positions& x) {
  Positions g;
  continuum_energy(model, x, 0.0, &g);
  return largest_vertex_norm(constrained_residual(g, evaluate_constraints(x, model.topo)));
}

/// Largest normal component of the Helfrich force alone after the constraints (pN): the
/// residual of the discrete shape equation. Vertex normal: direction of dV/dx_i.
double helfrich_normal_residual_pN(const Positions& x, const Topology& topo,
                                   const BendingParameters& b) {
  Positions g = Positions::Zero(3, x.cols());
  juelicher_bending_energy(x, topo, b, &g);
  const ConstraintValues c = evaluate_constraints(x, topo);
  const Positions r = constrained_residual(g, c);
  double worst = 0;
  for (Eigen::Index i = 0; i < x.cols(); ++i)
    worst = std::max(worst, std::abs(c.grad_volume.col(i).normalized().dot(r.col(i))));
  return worst;
}

/// The solve's residual bound carried to the test's least-squares multipliers: these minimise
/// the 2-norm, so |r_ls|_inf <= |r_ls|_2 <= |r_solver|_2 <= sqrt(3N) |r_solver|_inf.
double residual_bound_pN(const NewtonOptions& no, const Positions& x) {
  return std::sqrt(static_cast<double>(x.size())) * no.force_tolerance_pN;
}

/// Area and volume recomputed from the positions, relative to the rest mesh's.
void expect_constraints_held(const TriMesh& rest, const Positions& x, double tolerance) {
  const ConstraintValues c0 = evaluate_constraints(rest.x, rest.topo);
  const ConstraintValues c1 = evaluate_constraints(x, rest.topo);
  EXPECT_LE(std::abs(c1.area_um2 / c0.area_um2 - 1), tolerance);
  EXPECT_LE(std::abs(c1.volume_um3 / c0.volume_um3 - 1), tolerance);
}

double mean_edge_length_um(const TriMesh& m) {
  double sum = 0;
  for (int e = 0; e < m.topo.num_edges(); ++e)
    sum += (m.x.col(m.topo.edges(0, e)) - m.x.col(m.topo.edges(1, e))).norm();
  return sum / m.topo.num_edges();
}

/// Largest |H_i R / 2 - 1| over the Juelicher vertex cells (H_i = M_i / A_i, 1/um).
double largest_mean_curvature_deviation(const Positions& x, const Topology& topo, double r_um) {
  const JuelicherHessianTerms t = juelicher_hessian_terms(x, topo, {1.0, 0.0});
  double worst = 0;
  for (const JuelicherCell& c : t.cells)
    worst = std::max(worst, std::abs(c.h_per_um * r_um / 2 - 1));
  return worst;
}

TEST(RelaxHelfrich, SphereKeepsTheClosedFormEnergyAndUniformMeanCurvature) {
  const double kappa = 0.2;  // pN um
  NewtonOptions no;
  no.force_tolerance_pN = 1e-8;
  for (double radius : {1.0, 3.0})
    for (double h0 : {0.0, 0.5}) {
      SCOPED_TRACE("R = " + std::to_string(radius) + " um, H0 = " + std::to_string(h0) + " /um");
      const TriMesh mesh = testing::sphere_mesh(8, radius);  // 642 vertices, 1,280 faces
      const BendingParameters b{kappa, h0};
      const RelaxResult r = relax_helfrich(mesh, b, regulariser(1e-2), no);
      ASSERT_TRUE(r.solve.converged()) << to_string(r.solve.status) << ", " << r.solve.residual_pN;
      expect_constraints_held(mesh, r.x, no.constraint_tolerance);
      // The reported energies are the Helfrich energy of the start and of the end.
      EXPECT_NEAR(r.energy_before_pNum, juelicher_bending_energy(mesh.x, mesh.topo, b),
                  1e-12 * r.energy_before_pNum);
      EXPECT_NEAR(r.energy_after_pNum, juelicher_bending_energy(r.x, mesh.topo, b),
                  1e-12 * r.energy_before_pNum);
      EXPECT_LE(r.energy_after_pNum, r.energy_before_pNum);

      // The only smooth surface with the sphere's area and volume is that sphere (isoperimetric
      // equality), so it is the constrained stationary state for every H0:
      //   F_CH = (kappa/2) (2/R - H0)^2 4 pi R^2 = 2 pi kappa (2 - H0 R)^2,
      // R the radius of the polyhedron's area. Tolerance: the discretisation error of the
      // frequency-8 icosphere, the start's distance from 8 pi kappa at H0 = 0 (1.8e-3 of
      // 8 pi kappa; O(h^2), BendingConvergence), with a factor 1.5 for the H0 terms. Measured:
      // at most 0.89 of that error.
      const ConstraintValues c = evaluate_constraints(mesh.x, mesh.topo);
      const double ra = std::sqrt(c.area_um2 / (4 * units::pi));
      const double closed = 2 * units::pi * kappa * (2 - h0 * ra) * (2 - h0 * ra);
      const double discretisation = std::abs(
          juelicher_bending_energy(mesh.x, mesh.topo, {kappa, 0.0}) - 8 * units::pi * kappa);
      EXPECT_NEAR(r.energy_after_pNum, closed, 1.5 * discretisation);

      // Stationary: the Lagrangian's gradient vanishes with the test's own multipliers.
      ContinuumParameters p;
      p.bending = b;
      const ContinuumModel model = build_continuum_model(mesh, regulariser(1e-2), p);
      EXPECT_GT(lagrangian_residual_pN(model, mesh.x), 1e3 * residual_bound_pN(no, mesh.x));
      EXPECT_LE(lagrangian_residual_pN(model, r.x), residual_bound_pN(no, r.x));

      // Still a sphere, within the O(h^2) of the mesh (h = mean edge, h/R = 0.15 at frequency 8):
      // radii about the centroid and the vertices' mean curvature 2/R. The icosphere's start
      // has it wrong by up to 14 % (5 h^2 is 11 %); the relaxation evens it out (measured:
      // below 0.7 % everywhere).
      const double h2 = std::pow(mean_edge_length_um(mesh) / radius, 2);
      const Eigen::Vector3d centre = r.x.rowwise().mean();
      const Eigen::ArrayXd radii = (r.x.colwise() - centre).colwise().norm().transpose().array();
      EXPECT_LE((radii.maxCoeff() - radii.minCoeff()) / ra, h2);
      EXPECT_LE(r.largest_displacement_um, h2 * ra);
      EXPECT_GT(largest_mean_curvature_deviation(mesh.x, mesh.topo, ra), 5 * h2);
      EXPECT_LE(largest_mean_curvature_deviation(r.x, mesh.topo, ra), h2);
    }
}

TEST(RelaxHelfrich, EvansFungShapeBecomesStationaryAndTheRegulariserBarelyMatters) {
  const TriMesh mesh = make_continuum_mesh(1000);  // 502 vertices, 1,000 faces
  const double weight = 1e-2;                      // `rbc relax --regulariser` default
  NewtonOptions no;
  no.force_tolerance_pN = 1e-8;
  for (double h0 : {0.0, 0.1}) {  // `rbc relax --h0` default list
    SCOPED_TRACE("H0 = " + std::to_string(h0) + " /um");
    const BendingParameters b{0.2, h0};
    const RelaxResult r = relax_helfrich(mesh, b, regulariser(weight), no);
    const RelaxResult half = relax_helfrich(mesh, b, regulariser(0.5 * weight), no);
    ASSERT_TRUE(r.solve.converged()) << to_string(r.solve.status) << ", " << r.solve.residual_pN;
    ASSERT_TRUE(half.solve.converged()) << to_string(half.solve.status);
    expect_constraints_held(mesh, r.x, no.constraint_tolerance);
    expect_constraints_held(mesh, half.x, no.constraint_tolerance);

    // The Helfrich energy falls (measured: by 3.8 % at H0 = 0, 4.9 % at 0.1 /um).
    EXPECT_NEAR(r.energy_after_pNum, juelicher_bending_energy(r.x, mesh.topo, b),
                1e-12 * r.energy_before_pNum);
    EXPECT_LT(r.energy_after_pNum, 0.99 * r.energy_before_pNum);
    // Willmore: every closed surface has (kappa/2) int H^2 dA >= 8 pi kappa (measured 1.84x).
    if (h0 == 0.0) {
      EXPECT_GT(r.energy_after_pNum, 8 * units::pi * b.kappa_pNum);
    }

    // Stationary for the model relaxed: the Lagrangian's gradient vanishes.
    ContinuumParameters p;
    p.bending = b;
    const ContinuumModel model = build_continuum_model(mesh, regulariser(weight), p);
    EXPECT_GT(lagrangian_residual_pN(model, mesh.x), 1e3 * residual_bound_pN(no, mesh.x));
    EXPECT_LE(lagrangian_residual_pN(model, r.x), residual_bound_pN(no, r.x));

    // For Helfrich alone, what remains of the normal force (the shape equation's residual) is
    // the regulariser's: 1/100 of the start's or less (measured 1/250), and linear in the
    // weight, so halving the weight halves it (measured ratio 2.01 and 2.04).
    const double start = helfrich_normal_residual_pN(mesh.x, mesh.topo, b);
    const double end = helfrich_normal_residual_pN(r.x, mesh.topo, b);
    const double end_half = helfrich_normal_residual_pN(half.x, mesh.topo, b);
    EXPECT_LT(end, 1e-2 * start);
    EXPECT_GT(end / end_half, 1.6);
    EXPECT_LT(end / end_half, 2.4);

    // The regulariser's share of the energy (relax.hpp: ~1e-3 of the bending energy; measured
    // 9e-4 and 1.2e-3), recomputed from the model: in-plane energy above the rest mesh's.
    EXPECT_NEAR(r.regulariser_energy_pNum,
                membrane_energy(model, r.x) - membrane_energy(model, model.rest),
                1e-9 * r.energy_after_pNum);
    EXPECT_GT(r.regulariser_energy_pNum, 0.0);
    EXPECT_LT(r.regulariser_energy_pNum, 2e-3 * r.energy_after_pNum);

    // Its effect on the shape, linear in the weight: the relaxed shape at weight w differs from
    // the w -> 0 limit by about 2 x its difference from the shape at w/2. Bounds: 1/5 of the
    // relaxation's own largest displacement (measured 0.08), and 1/50 of its energy drop
    // (measured 0.007).
    double shape_change = 0;
    for (Eigen::Index i = 0; i < r.x.cols(); ++i)
      shape_change = std::max(shape_change, (r.x.col(i) - half.x.col(i)).norm());
    EXPECT_LT(2 * shape_change, 0.2 * r.largest_displacement_um);
    EXPECT_LT(2 * std::abs(r.energy_after_pNum - half.energy_after_pNum),
              0.02 * (r.energy_before_pNum - r.energy_after_pNum));
  }
}

}  // namespace
}  // namespace rbc
