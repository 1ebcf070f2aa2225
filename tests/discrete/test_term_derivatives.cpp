// SPDX-License-Identifier: GPL-3.0-or-later
// Per-term finite-difference tests (STYLE.md 2): every discrete energy term's
// value, gradient and (where Newton uses it) Hessian, through the term's own unit, on a
// randomly perturbed cell mesh; the central-difference error must decay at second order as
// h halves (observed order in [1.8, 2.2], tests/fd_order.hpp).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <vector>

#include "core/block_pattern.hpp"
#include "core/geometry.hpp"
#include "discrete/bending_energy.hpp"
#include "discrete/constraint_energy.hpp"
#include "discrete/element_hessian.hpp"
#include "discrete/link_energy.hpp"
#include "discrete/network.hpp"
#include "discrete/steric_energy.hpp"
#include "discrete/tweezers.hpp"
#include "discrete_cell_fixture.hpp"
#include "fd_order.hpp"

namespace rbc {
namespace {

using testing::SmallCell;
using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;

Positions as_positions(const Vec& v) {
  return Eigen::Map<const Eigen::Matrix3Xd>(v.data(), 3, v.size() / 3);
}

double mean_edge_um(const SmallCell& c) {
  return c.net.lbar_um.mean();
}

/// A term on the whole mesh: value and gradient from one call, Hessian dense (small mesh).
struct Term {
  std::function<double(const Positions&, Positions*)> value_gradient;
  std::function<Mat(const Positions&)> hessian;  ///< empty where no Hessian exists
};

void expect_term_second_order(const Term& t, const Positions& x, double length,
                              const std::string& what) {
  const auto energy = [&](const Vec& v) { return t.value_gradient(as_positions(v), nullptr); };
  const auto grad = [&](const Vec& v) {
    Positions g = Positions::Zero(3, v.size() / 3);
    t.value_gradient(as_positions(v), &g);
    return Vec(flat(g));
  };
  const Vec x0 = flat(x);
  for (unsigned seed : {1u, 2u}) {
    testing::expect_second_order(testing::gradient_order(energy, x0, grad(x0), length, seed),
                                 what + " gradient, direction " + std::to_string(seed));
    if (t.hessian) {
      const Mat h = t.hessian(x);
      EXPECT_LT((h - h.transpose()).norm(), 1e-12 * h.norm()) << what << " Hessian symmetry";
      testing::expect_second_order(
          testing::hessian_order(
              grad, x0, [&](const Vec& d) -> Vec { return h * d; }, length, seed),
          what + " Hessian, direction " + std::to_string(seed));
    }
  }
}

void add_block(Mat& h, int i, int j, const Eigen::Matrix3d& b) {
  h.block<3, 3>(3 * i, 3 * j) += b;
}

template <int K>
void add_local(Mat& h, const int (&v)[K], const Eigen::Matrix<double, 3 * K, 3 * K>& m) {
  for (int a = 0; a < K; ++a)
    for (int b = 0; b < K; ++b) add_block(h, v[a], v[b], m.template block<3, 3>(3 * a, 3 * b));
}

TEST(TermDerivatives, WlcLinkValueGradientHessian) {
  SmallCell c;
  const Network& n = c.net;
  const Topology& t = n.topo;
  // Stretch 20% beyond rest so V'' and V''' are far from their rest values.
  const Positions x = 1.2 * c.x;
  Term term;
  term.value_gradient = [&](const Positions& p, Positions* g) {
    double e = 0;
    for (int k = 0; k < t.num_edges(); ++k) {
      const int a = t.edges(0, k), b = t.edges(1, k);
      Eigen::Vector3d gb;
      e += link_energy(n.wlc, n.lbar_um(k), p.col(a), p.col(b), g ? &gb : nullptr);
      if (g) {
        g->col(b) += gb;
        g->col(a) -= gb;
      }
    }
    return e;
  };
  term.hessian = [&](const Positions& p) {
    Mat h = Mat::Zero(p.size(), p.size());
    for (int k = 0; k < t.num_edges(); ++k) {
      const int a = t.edges(0, k), b = t.edges(1, k);
      Eigen::Matrix3d hb;
      link_energy(n.wlc, n.lbar_um(k), p.col(a), p.col(b), nullptr, &hb);
      add_block(h, a, a, hb);
      add_block(h, b, b, hb);
      add_block(h, a, b, -hb);
      add_block(h, b, a, -hb);
    }
    return h;
  };
  expect_term_second_order(term, x, mean_edge_um(c), "WLC link");
}

TEST(TermDerivatives, StericFaceValueGradientHessian) {
  SmallCell c;
  const Network& n = c.net;
  const Topology& t = n.topo;
  const Positions x = 0.9 * c.x;  // compressed: the steric term is far from its rest slope
  Term term;
  term.value_gradient = [&](const Positions& p, Positions* g) {
    double e = 0;
    for (int f = 0; f < t.num_faces(); ++f) {
      const auto v = t.faces.col(f);
      Eigen::Matrix3d gf;
      e += steric_face_energy(n.steric_C_pN_per_um, n.steric, n.abar_um2(f), p.col(v(0)),
                              p.col(v(1)), p.col(v(2)), g ? &gf : nullptr);
      if (g)
        for (int k = 0; k < 3; ++k) g->col(v(k)) += gf.col(k);
    }
    return e;
  };
  term.hessian = [&](const Positions& p) {
    Mat h = Mat::Zero(p.size(), p.size());
    for (int f = 0; f < t.num_faces(); ++f) {
      const int v[3] = {t.faces(0, f), t.faces(1, f), t.faces(2, f)};
      add_local<3>(h, v,
                   steric_face_hessian(n.steric_C_pN_per_um, n.steric, n.abar_um2(f), p.col(v[0]),
                                       p.col(v[1]), p.col(v[2])));
    }
    return h;
  };
  expect_term_second_order(term, x, mean_edge_um(c), "steric face");
}

TEST(TermDerivatives, JuelicherValueGradientHessian) {
  SmallCell c;
  const Topology& t = c.net.topo;
  const BendingParameters p{0.2, 0.7};  // kappa (pN um), H0 (1/um): every Hessian part active
  // The exact Hessian through the one block assembler, over the closed-star pattern.
  const VertexStars stars = make_vertex_stars(t);
  std::vector<std::vector<int>> cols(t.num_vertices);
  for (int v = 0; v < t.num_vertices; ++v)
    for (int a = 0; a < stars.size(v); ++a)
      for (int b = 0; b < stars.size(v); ++b) cols[stars.begin(v)[b]].push_back(stars.begin(v)[a]);
  Term term;
  term.value_gradient = [&](const Positions& x, Positions* g) {
    return juelicher_bending_energy(x, t, p, g);
  };
  term.hessian = [&](const Positions& x) {
    BlockMatrix h(cols, BlockStorage::full);
    add_juelicher_hessian(x, t, p, h);
    return Mat(h.matrix());
  };
  expect_term_second_order(term, c.x, mean_edge_um(c), "Juelicher bending");
  // The cells carry the whole energy: sum_v (kappa/2) h_v^2 A_v, and sum_v A_v = total area.
  const JuelicherHessianTerms parts = juelicher_hessian_terms(c.x, t, p);
  double e = 0, area = 0;
  for (const JuelicherCell& cell : parts.cells) {
    e += cell.energy_pNum;
    area += cell.a_um2;
  }
  EXPECT_NEAR(e, juelicher_bending_energy(c.x, t, p), 1e-12 * e);
  double total_area = 0;
  for (int f = 0; f < t.num_faces(); ++f)
    total_area +=
        triangle_area(c.x.col(t.faces(0, f)), c.x.col(t.faces(1, f)), c.x.col(t.faces(2, f)));
  EXPECT_NEAR(area, total_area, 1e-12 * total_area);
}

TEST(TermDerivatives, DihedralValueGradient) {
  // Kantor-Nelson hinges: value and gradient (the Newton preconditioner uses only the
  // Gauss-Newton part k_b cos(theta - theta0) dtheta dtheta^T, tested in
  // test_network_hessian.cpp).
  SmallCell c;
  Term term;
  term.value_gradient = [&](const Positions& x, Positions* g) {
    return dihedral_bending_energy(x, c.net.topo, 0.7, 0.05, g);
  };
  expect_term_second_order(term, c.x, mean_edge_um(c), "dihedral bending");
}

TEST(TermDerivatives, AreaVolumePenaltyValueGradientHessian) {
  SmallCell c;
  const Network& n = c.net;
  const Topology& t = n.topo;
  const ConstraintMultipliers lambda{2.0, -1.0};
  const Positions x = 1.05 * c.x;  // off the constraint: the penalty's curvature is active
  Term term;
  term.value_gradient = [&](const Positions& p, Positions* g) {
    return constraint_energy(p, t, n.area0_um2, n.volume0_um3, n.constraints, lambda, g);
  };
  // E = lA (A - A0) + kA/2 (A - A0)^2 + (V likewise):
  // d2E = (lA + kA (A - A0)) d2A + kA dA dA^T + (lV + kV (V - V0)) d2V + kV dV dV^T.
  term.hessian = [&](const Positions& p) {
    const int m = static_cast<int>(p.size());
    Mat d2a = Mat::Zero(m, m), d2v = Mat::Zero(m, m);
    Vec da = Vec::Zero(m), dv = Vec::Zero(m);
    double area = 0, volume = 0;
    for (int f = 0; f < t.num_faces(); ++f) {
      const int v[3] = {t.faces(0, f), t.faces(1, f), t.faces(2, f)};
      Vector9d ga;
      Matrix9d ha;
      area += triangle_area_hessian(p.col(v[0]), p.col(v[1]), p.col(v[2]), &ga, &ha);
      Eigen::Matrix3d gv;
      volume += tetra_volume(p.col(v[0]), p.col(v[1]), p.col(v[2]), &gv);
      add_local<3>(d2a, v, ha);
      add_local<3>(d2v, v, tetra_volume_hessian(p.col(v[0]), p.col(v[1]), p.col(v[2])));
      for (int k = 0; k < 3; ++k) {
        da.segment<3>(3 * v[k]) += ga.segment<3>(3 * k);
        dv.segment<3>(3 * v[k]) += gv.col(k);
      }
    }
    const double ka = n.constraints.area_stiffness_pN_per_um3;
    const double kv = n.constraints.volume_stiffness_pN_per_um5;
    return Mat((lambda.area_pN_per_um + ka * (area - n.area0_um2)) * d2a +
               ka * da * da.transpose() +
               (lambda.volume_pN_per_um2 + kv * (volume - n.volume0_um3)) * d2v +
               kv * dv * dv.transpose());
  };
  expect_term_second_order(term, x, mean_edge_um(c), "area/volume penalty");
}

TEST(TermDerivatives, TweezersAreLinearWithExactGradient) {
  // The bead work is linear in x: the central difference has no truncation error, so there
  // is no order to observe; the truth is exactness (round-off only) and a zero Hessian:
  // the gradient does not depend on x.
  SmallCell c;
  const auto energy = [&](const Vec& v) {
    return tweezers_energy(c.net.patch, 77.0, as_positions(v), c.net.rest);
  };
  Positions g = Positions::Zero(3, c.x.cols()), g2 = g;
  tweezers_energy(c.net.patch, 77.0, c.x, c.net.rest, &g);
  tweezers_energy(c.net.patch, 77.0, 1.3 * c.x, c.net.rest, &g2);
  EXPECT_EQ((g - g2).cwiseAbs().maxCoeff(), 0.0);
  // Each bead pulls with the whole force: the shares on each side sum to -+F.
  EXPECT_NEAR(g.row(0).sum(), 0.0, 1e-12 * 77.0);
  double plus = 0;
  for (Eigen::Index i = 0; i < g.cols(); ++i) plus += std::min(g(0, i), 0.0);
  EXPECT_NEAR(plus, -77.0, 1e-12 * 77.0);
  const testing::FdOrder r =
      testing::gradient_order(energy, flat(c.x), flat(g), mean_edge_um(c), 3);
  EXPECT_LT(r.err_h, 1e-9 * r.scale);
  EXPECT_LT(r.err_small, r.roundoff);
}

}  // namespace
}  // namespace rbc
