// SPDX-License-Identifier: GPL-3.0-or-later
// Convergence of the continuum model's Canham-Helfrich discretisation (Juelicher's operator,
// shared with discrete/) under mesh refinement, against independent truths: 8 pi kappa on
// the sphere, and the Evans-Fung surface's F_CH by 1D quadrature of the surface of
// revolution. The observed orders are printed and checked within a band.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "continuum/continuum_model.hpp"
#include "continuum/evans_fung_reference.hpp"
#include "core/units.hpp"
#include "discrete/bending_energy.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace {

double order(double e_coarse, double e_fine, double h_ratio) {
  return std::log(e_coarse / e_fine) / std::log(h_ratio);
}

TEST(BendingConvergence, SphereApproaches8PiKappaAtSecondOrder) {
  const double kappa = 0.2, exact = 8 * units::pi * kappa;
  std::vector<double> err;
  for (int f : {4, 8, 16}) {
    const TriMesh m = testing::sphere_mesh(f, 2.5);
    err.push_back(std::abs(juelicher_bending_energy(m.x, m.topo, {kappa, 0.0}) / exact - 1));
  }
  const double p1 = order(err[0], err[1], 2), p2 = order(err[1], err[2], 2);
  std::cout << "[ sphere ] relative errors " << err[0] << " " << err[1] << " " << err[2]
            << ", observed orders " << p1 << " " << p2 << "\n";
  EXPECT_LT(err[2], 1e-3);
  EXPECT_GT(p2, 1.7);
  EXPECT_LT(p2, 2.5);
}

TEST(BendingConvergence, EvansFungShapeConverges) {
  const EvansFungShape shape;
  const double kappa = 0.2, exact = testing::evans_fung_helfrich_energy(shape, kappa);
  // Quadrature check of the oracle itself: the sphere profile (c0 = 1, c1 = c2 = 0).
  EXPECT_NEAR(
      testing::evans_fung_helfrich_energy({2.0, 1.0, 0.0, 0.0}, kappa) / (8 * units::pi * kappa),
      1.0, 1e-8);
  std::vector<double> err;
  const std::vector<int> elements = {500, 2000, 8000};
  for (int el : elements) {
    const TriMesh m = make_continuum_mesh(el, shape);
    err.push_back(std::abs(juelicher_bending_energy(m.x, m.topo, {kappa, 0.0}) / exact - 1));
  }
  const double p1 = order(err[0], err[1], 2), p2 = order(err[1], err[2], 2);
  std::cout << "[ Evans-Fung ] F_CH exact " << exact << " pN um, relative errors " << err[0] << " "
            << err[1] << " " << err[2] << ", observed orders " << p1 << " " << p2 << "\n";
  EXPECT_LT(err[2], err[1]);
  EXPECT_LT(err[1], err[0]);
  EXPECT_GT(p2, 1.5);
}

}  // namespace
}  // namespace rbc
