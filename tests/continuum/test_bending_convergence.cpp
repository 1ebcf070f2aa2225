// SPDX-License-Identifier: GPL-3.0-or-later
// Convergence of the continuum model's Canham-Helfrich discretisation (Juelicher's operator,
// shared with discrete/) under mesh refinement, against independent truths: 8 pi kappa on
// the sphere, and the Evans-Fung surface's F_CH by 1D quadrature of the surface of
// revolution. The observed orders are printed and checked within a band.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "continuum/continuum_model.hpp"
#include "core/units.hpp"
#include "discrete/bending_energy.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace {

// F_CH = 2 int_0^{pi/2} (kappa/2) H^2 2 pi r |gamma'| dt for the upper half profile
// r = R sin t, z = R cos t g(sin^2 t), g(s) = c0 + c1 s + c2 s^2 (smooth at the rim), with
// meridian curvature (r' z'' - z' r'')/|gamma'|^3 and parallel curvature z'/(r |gamma'|).
double evans_fung_helfrich_energy(const EvansFungShape& s, double kappa) {
  const int n = 200000;
  const double h = 0.5 * units::pi / n, R = s.radius_um;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const double t = (i + 0.5) * h, sn = std::sin(t), cs = std::cos(t);
    const double u = sn * sn, du = 2 * sn * cs, d2u = 2 * (cs * cs - sn * sn);
    const double g = s.c0 + s.c1 * u + s.c2 * u * u, dg = (s.c1 + 2 * s.c2 * u) * du;
    const double d2g = 2 * s.c2 * du * du + (s.c1 + 2 * s.c2 * u) * d2u;
    const double r = R * sn, dr = R * cs, d2r = -R * sn;
    const double z = R * cs * g;
    (void)z;
    const double dz = R * (-sn * g + cs * dg), d2z = R * (-cs * g - 2 * sn * dg + cs * d2g);
    const double speed = std::sqrt(dr * dr + dz * dz);
    const double k1 = (dr * d2z - dz * d2r) / (speed * speed * speed);
    const double k2 = dz / (r * speed);
    const double hh = k1 + k2;
    sum += 0.5 * kappa * hh * hh * 2 * units::pi * r * speed * h;
  }
  return 2 * sum;
}

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
  const double kappa = 0.2, exact = evans_fung_helfrich_energy(shape, kappa);
  // Quadrature check of the oracle itself: the sphere profile (c0 = 1, c1 = c2 = 0).
  EXPECT_NEAR(evans_fung_helfrich_energy({2.0, 1.0, 0.0, 0.0}, kappa) / (8 * units::pi * kappa),
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
