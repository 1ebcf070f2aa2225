// SPDX-License-Identifier: GPL-3.0-or-later
// Per-term finite-difference tests of the continuum model (STYLE.md 2): the
// membrane element, the Helfrich (Juelicher) bending term and the area/volume constraint
// curvature, each through its own unit, on a randomly perturbed mesh; the central-difference
// error of the gradient and of the Hessian must decay at second order as h halves
// (observed order in [1.8, 2.2], tests/fd_order.hpp).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <string>

#include "continuum/block_hessian.hpp"
#include "continuum/continuum_model.hpp"
#include "continuum/membrane_element.hpp"
#include "fd_order.hpp"
#include "fixtures.hpp"
#include "p2_law.hpp"

namespace rbc {
namespace {

using Vec = Eigen::VectorXd;

Positions as_positions(const Vec& v) {
  return Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, v.size() / 3);
}

struct Model {
  ContinuumModel m;
  Positions x;
  double edge_um = 0;
  Model() {
    ContinuumParameters p;
    p.bending = {0.2, 0.5};  // kappa (pN um), H0 (1/um): every bending Hessian part active
    m = build_continuum_model(make_continuum_mesh(320), testing::closed_form_p2_law(), p);
    x = 1.05 * m.rest;  // stretched: the in-plane law is off its rest slope
    testing::perturb(x, 0.03, 8);
    const Eigen::VectorXd l = edge_lengths(m.rest, m.topo);
    edge_um = l.mean();
  }
};

using ValueGradient = std::function<double(const Positions&, Positions*)>;
using AddHessian = std::function<void(const Positions&, BlockHessian&)>;

void expect_term_second_order(const Model& s, const ValueGradient& vg, const AddHessian& add,
                              const std::string& what) {
  const auto energy = [&](const Vec& v) { return vg(as_positions(v), nullptr); };
  const auto grad = [&](const Vec& v) {
    Positions g = Positions::Zero(3, v.size() / 3);
    vg(as_positions(v), &g);
    return Vec(flat(g));
  };
  BlockHessian h(s.m.topo);
  h.set_zero();
  add(s.x, h);
  const Eigen::SparseMatrix<double>& hm = h.matrix();
  const Eigen::SparseMatrix<double> asym = hm - Eigen::SparseMatrix<double>(hm.transpose());
  EXPECT_LT(asym.norm(), 1e-12 * hm.norm()) << what << " Hessian symmetry";
  const Vec x0 = flat(s.x);
  for (unsigned seed : {1u, 2u}) {
    testing::expect_second_order(testing::gradient_order(energy, x0, grad(x0), s.edge_um, seed),
                                 what + " gradient, direction " + std::to_string(seed));
    testing::expect_second_order(
        testing::hessian_order(
            grad, x0, [&](const Vec& d) -> Vec { return hm * d; }, s.edge_um, seed),
        what + " Hessian, direction " + std::to_string(seed));
  }
}

TEST(ContinuumTermDerivatives, MembraneElements) {
  const Model s;
  expect_term_second_order(
      s,
      [&](const Positions& x, Positions* g) {
        if (g) g->setZero(3, x.cols());
        return membrane_energy(s.m, x, g);
      },
      [&](const Positions& x, BlockHessian& h) { add_membrane_hessian(s.m, x, h); },
      "membrane elements");
}

TEST(ContinuumTermDerivatives, HelfrichBending) {
  const Model s;
  expect_term_second_order(
      s,
      [&](const Positions& x, Positions* g) {
        return juelicher_bending_energy(x, s.m.topo, s.m.bending, g);
      },
      [&](const Positions& x, BlockHessian& h) {
        add_juelicher_hessian(x, s.m.topo, s.m.bending, h);
      },
      "Helfrich bending");
}

TEST(ContinuumTermDerivatives, AreaVolumeCurvature) {
  // sigma A + p V with fixed multipliers: the curvature part of the constraint Hessian.
  const Model s;
  const double sigma = 2.0, p = -1.5;  // pN/um, pN/um^2
  expect_term_second_order(
      s,
      [&](const Positions& x, Positions* g) {
        const ConstraintValues c = evaluate_constraints(x, s.m.topo);
        if (g) *g = sigma * c.grad_area + p * c.grad_volume;
        return sigma * c.area_um2 + p * c.volume_um3;
      },
      [&](const Positions& x, BlockHessian& h) {
        add_constraint_hessian(x, s.m.topo, sigma, p, h);
      },
      "area/volume curvature");
}

// The fused Lagrangian Hessian (one pass, shared triangle area Hessian, cached block codes):
// second order against the Lagrangian's gradient, and equal to the separate terms' sum to
// rounding in lower storage (what the Newton solver factorises) as in full.
TEST(ContinuumTermDerivatives, FusedLagrangianHessian) {
  const Model s;
  const double sigma = 1.7, p = -0.6, force = 40.0;  // pN/um, pN/um^2, pN
  const auto lagrangian = [&](const Positions& x, Positions* g) {
    const double e = continuum_energy(s.m, x, force, g);
    const ConstraintValues c = evaluate_constraints(x, s.m.topo);
    if (g) *g += sigma * c.grad_area + p * c.grad_volume;
    return e + sigma * c.area_um2 + p * c.volume_um3;
  };
  expect_term_second_order(
      s, lagrangian,
      [&](const Positions& x, BlockHessian& h) { add_lagrangian_hessian(s.m, x, sigma, p, h); },
      "fused Lagrangian");
  BlockHessian separate(s.m.topo);
  separate.set_zero();
  add_continuum_hessian(s.m, s.x, separate);
  add_constraint_hessian(s.x, s.m.topo, sigma, p, separate);
  const Eigen::MatrixXd reference = Eigen::MatrixXd(separate.matrix());
  for (const BlockStorage storage : {BlockStorage::full, BlockStorage::lower}) {
    BlockHessian fused(s.m.topo, storage);
    fused.set_zero();
    add_lagrangian_hessian(s.m, s.x, sigma, p, fused);
    const Eigen::SparseMatrix<double>& f = fused.matrix();
    const Eigen::MatrixXd dense =
        storage == BlockStorage::full
            ? Eigen::MatrixXd(f)
            : Eigen::MatrixXd(Eigen::SparseMatrix<double>(f.selfadjointView<Eigen::Lower>()));
    EXPECT_LT((dense - reference).cwiseAbs().maxCoeff(), 1e-12 * reference.cwiseAbs().maxCoeff())
        << (storage == BlockStorage::full ? "full" : "lower") << " storage";
  }
}

}  // namespace
}  // namespace rbc
