// SPDX-License-Identifier: GPL-3.0-or-later
// Mirror symmetry and the symmetry reduction (core/mirror_symmetry.hpp,
// core/reduced_problem.hpp) against independent truths: the symmetry group of the icosphere
// the rest shape is built from (a five-fold axis along z: the mirror y -> -y and the inversion
// and their product, not x -> -x or z -> -z), the dense matrix P built from its definition
// (x_{g(i)} = S_g x_i), P'HP computed densely, and a constrained spring network solved by the
// shifted Newton method with and without the reduction.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "core/mirror_symmetry.hpp"
#include "core/reduced_problem.hpp"
#include "core/rest_shape.hpp"
#include "core/shifted_newton.hpp"
#include "core/symmetry_stability.hpp"

namespace rbc {
namespace {

TriMesh rest_mesh(int vertices, unsigned rotation_seed = 0) {
  RestShapeOptions o;
  o.target_vertices = vertices;
  o.rotation_seed = rotation_seed;
  return make_rest_shape(o);
}

std::vector<int> sorted(std::vector<int> v) {
  std::sort(v.begin(), v.end());
  return v;
}

TEST(MirrorSymmetry, DefaultMeshKeepsTheIcosphereMirrorsAndARotatedOneNone) {
  // The icosahedron with a vertex at each pole and its rings 36 degrees apart is invariant
  // under y -> -y (mask 2), the inversion (7) and the half turn about y (5), not under
  // x -> -x (1), z -> -z (4) or the others.
  for (int n : {252, 1002}) {
    const TriMesh m = rest_mesh(n);
    const MeshSymmetry g = find_mirror_symmetry(m.x, m.topo);
    EXPECT_EQ(sorted(g.reflections), (std::vector<int>{0, 2, 5, 7})) << n << " vertices";
    for (int e = 0; e < g.order(); ++e) {
      const Eigen::Vector3d s(reflection_sign(g.reflections[e], 0),
                              reflection_sign(g.reflections[e], 1),
                              reflection_sign(g.reflections[e], 2));
      for (int i = 0; i < m.topo.num_vertices; ++i)
        ASSERT_LT((m.x.col(g.image[e][i]) - m.x.col(i).cwiseProduct(s)).norm(), kMirrorToleranceUm);
    }
  }
  // A turned icosphere keeps only its centre of symmetry: the inversion (the Evans-Fung map
  // commutes with it).
  const TriMesh r = rest_mesh(252, 3);
  EXPECT_EQ(find_mirror_symmetry(r.x, r.topo).reflections, (std::vector<int>{0, 7}));
  // One vertex moved by 1e-6 um (100 x the tolerance): no mirror left.
  TriMesh moved = rest_mesh(252);
  moved.x(0, 17) += 1e-6;
  EXPECT_EQ(find_mirror_symmetry(moved.x, moved.topo).order(), 1);
}

TEST(MirrorSymmetry, KeepInvariantDropsTheMirrorsThatMoveAWeight) {
  const TriMesh m = rest_mesh(252);
  const MeshSymmetry g = find_mirror_symmetry(m.x, m.topo);
  // A weight on the vertex of largest x and minus it on its mirror image through the origin:
  // odd in x, so the inversion and the half turn about y keep it (sign of x), y -> -y keeps it
  // only if the vertex lies on the plane y = 0.
  int far = -1;
  for (int i = 0; i < m.topo.num_vertices; ++i)
    if (std::abs(m.x(1, i)) > 1e-3 && (far < 0 || m.x(0, i) > m.x(0, far))) far = i;
  ASSERT_GE(far, 0);
  const int inv = g.image[std::find(g.reflections.begin(), g.reflections.end(), 7) -
                          g.reflections.begin()][far];
  const MeshSymmetry kept = keep_invariant(g, {far, inv}, {1.0, -1.0}, 0, 1e-12);
  EXPECT_EQ(sorted(kept.reflections), (std::vector<int>{0, 7}));
}

TEST(MirrorSymmetry, ElementsThatPassOneByOneAreCutToTheLargestSubgroup) {
  // Four vertices permuted as the group {0, 1, 2, 3} of sign masks (none flips z, the sign
  // coordinate) acts on itself, i -> i XOR g; the weight f(i) = 0.6 (bit 0 + bit 1) moves by
  // 0.6 under masks 1 and 2 (within the tolerance 1) but by 1.2 under mask 3 = 1 XOR 2. The
  // elements that pass, {0, 1, 2}, are not closed: the result is the first largest subgroup.
  MeshSymmetry g;
  g.reflections = {0, 1, 2, 3};
  for (int mask : g.reflections) {
    std::vector<int> image(4);
    for (int i = 0; i < 4; ++i) image[i] = i ^ mask;
    g.image.push_back(image);
  }
  const std::vector<double> w{0.0, 0.6, 0.6, 1.2};
  const MeshSymmetry kept = keep_invariant(g, {0, 1, 2, 3}, w, 2, 1.0);
  EXPECT_EQ(kept.reflections, (std::vector<int>{0, 1}));
  ASSERT_EQ(kept.image.size(), 2u);
  EXPECT_EQ(kept.image[1], (std::vector<int>{1, 0, 3, 2}));
  // All four pass with a looser tolerance.
  EXPECT_EQ(keep_invariant(g, {0, 1, 2, 3}, w, 2, 1.3).order(), 4);
}

/// The dense P of a reduction from its definition: column a has sign_i at every full
/// coordinate i mapped to a.
Eigen::MatrixXd dense_p(const SymmetryReduction& r) {
  Eigen::MatrixXd p = Eigen::MatrixXd::Zero(r.full_size, r.reduced_size);
  for (int i = 0; i < r.full_size; ++i)
    if (r.reduced_index[i] >= 0) p(i, r.reduced_index[i]) = r.sign[i];
  return p;
}

/// Random symmetric matrix on the vertex-adjacency block pattern of a mesh (lower triangle
/// stored when lower is true, both triangles otherwise), compressed.
Eigen::SparseMatrix<double> random_block_matrix(const Topology& t, bool lower, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 3 * t.num_vertices;
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n, n);
  auto block = [&](int i, int j) {
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        const double v = u(rng);
        dense(3 * i + a, 3 * j + b) += v;
        dense(3 * j + b, 3 * i + a) += v;
      }
  };
  for (int i = 0; i < t.num_vertices; ++i) block(i, i);
  for (int e = 0; e < t.num_edges(); ++e) block(t.edges(0, e), t.edges(1, e));
  std::vector<Eigen::Triplet<double>> trip;
  for (int c = 0; c < n; ++c)
    for (int r = 0; r < n; ++r)
      if (dense(r, c) != 0.0 && (!lower || r >= c)) trip.emplace_back(r, c, dense(r, c));
  Eigen::SparseMatrix<double> h(n, n);
  h.setFromTriplets(trip.begin(), trip.end());
  h.makeCompressed();
  return h;
}

/// The symmetric matrix whose lower triangle h stores, dense.
Eigen::MatrixXd dense_symmetric(const Eigen::SparseMatrix<double>& h) {
  Eigen::SparseMatrix<double> full = h.selfadjointView<Eigen::Lower>();
  return Eigen::MatrixXd(full);
}

TEST(MirrorSymmetry, ReductionMatchesTheDenseProjection) {
  const TriMesh m = rest_mesh(252);
  const MeshSymmetry g = find_mirror_symmetry(m.x, m.topo);
  const SymmetryReduction red = make_symmetry_reduction(g);
  const Eigen::MatrixXd p = dense_p(red);
  // Every orbit of four vertices has 3 free coordinates, smaller orbits fewer: |G| times
  // fewer unknowns up to the vertices on mirror planes and axes.
  EXPECT_EQ(red.group_order, 4);
  EXPECT_NEAR(static_cast<double>(red.reduced_size), red.full_size / 4.0, 0.02 * red.full_size);
  // P'P = diag(orbit sizes).
  Eigen::VectorXd orbit(red.reduced_size);
  for (int a = 0; a < red.reduced_size; ++a) orbit(a) = red.orbit_size[red.orbit_of_entry[a]];
  EXPECT_LT((p.transpose() * p - Eigen::MatrixXd(orbit.asDiagonal())).norm(), 1e-14);
  std::mt19937 rng(5);
  std::normal_distribution<double> nd;
  Eigen::VectorXd q(red.reduced_size), v(red.full_size);
  for (auto& e : q) e = nd(rng);
  for (auto& e : v) e = nd(rng);
  // expand is P q, and P q is symmetric: x_{g(i)} = S_g x_i.
  const Eigen::VectorXd x = expand(red, q);
  EXPECT_LT((x - p * q).norm(), 1e-14);
  for (int e = 0; e < g.order(); ++e)
    for (int i = 0; i < m.topo.num_vertices; ++i)
      for (int k = 0; k < 3; ++k)
        ASSERT_DOUBLE_EQ(x(3 * g.image[e][i] + k),
                         reflection_sign(g.reflections[e], k) * x(3 * i + k));
  EXPECT_LT((reduce(red, v) - p.transpose() * v).norm(), 1e-13);
  EXPECT_LT((symmetric_part(red, x) - q).norm(), 1e-14);
  // The per-vertex norms: of a symmetric force from its reduction, of a step from q.
  const Eigen::Map<const Eigen::Matrix3Xd> xv(x.data(), 3, m.topo.num_vertices);
  EXPECT_NEAR(largest_vertex_norm_of_reduced(red, p.transpose() * x),
              xv.colwise().norm().maxCoeff(), 1e-13);
  EXPECT_NEAR(largest_vertex_norm_of_expanded(red, q), xv.colwise().norm().maxCoeff(), 1e-13);
  // P' H P, from lower and from full storage.
  for (bool lower : {true, false}) {
    const Eigen::SparseMatrix<double> h = random_block_matrix(m.topo, lower, 11);
    const Eigen::MatrixXd hd = lower ? dense_symmetric(h) : Eigen::MatrixXd(h);
    ReducedMatrix map(red, h);
    const Eigen::SparseMatrix<double>& hr = map.reduce(h);
    const Eigen::MatrixXd expected = p.transpose() * hd * p;
    const Eigen::MatrixXd got = dense_symmetric(hr);
    EXPECT_LT((got - expected).norm(), 1e-12 * expected.norm()) << (lower ? "lower" : "full");
  }
}

TEST(MirrorSymmetry, TrivialGroupIsTheIdentityMap) {
  TriMesh m = rest_mesh(252);
  m.x(1, 40) += 1e-6;
  const SymmetryReduction red = make_symmetry_reduction(find_mirror_symmetry(m.x, m.topo));
  EXPECT_TRUE(red.trivial());
  EXPECT_EQ(red.reduced_size, red.full_size);
  Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(red.full_size, -1.0, 2.0);
  EXPECT_EQ(expand(red, v), v);
  EXPECT_EQ(reduce(red, v), v);
}

/// A spring network on the mesh edges (rest lengths of the mesh) pulled apart at the
/// vertices of largest and smallest x (+-F along x), tethered to the rest shape
/// (k_t |x - X|^2 / 2, as stiff as the springs: one minimum, no floppy modes, so the full
/// minimum is the symmetric one), with the constraint sum |x_i|^2 = its rest value.
/// Invariant under every mirror of the mesh that maps the pulled vertices onto each other.
struct SpringScene {
  TriMesh mesh;
  int plus = 0, minus = 0;
  double k = 2.0, tether = 1.0, force = 3.0, moment0 = 0.0;
  Eigen::VectorXd rest_length;
  NewtonProblem problem;
  Eigen::SparseMatrix<double> h;
};

std::unique_ptr<SpringScene> spring_scene(int vertices) {
  auto s = std::make_unique<SpringScene>();
  s->mesh = rest_mesh(vertices);
  const Topology& t = s->mesh.topo;
  const Positions& x0 = s->mesh.x;
  for (int i = 0; i < t.num_vertices; ++i) {
    if (x0(0, i) > x0(0, s->plus)) s->plus = i;
    if (x0(0, i) < x0(0, s->minus)) s->minus = i;
  }
  s->rest_length.resize(t.num_edges());
  for (int e = 0; e < t.num_edges(); ++e)
    s->rest_length(e) = (x0.col(t.edges(0, e)) - x0.col(t.edges(1, e))).norm();
  s->moment0 = x0.squaredNorm();
  SpringScene* sc = s.get();
  // Pattern: vertex blocks on the diagonal and on the edges (lower triangle).
  std::vector<Eigen::Triplet<double>> trip;
  auto block = [&](int i, int j) {
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        if (3 * i + a >= 3 * j + b) trip.emplace_back(3 * i + a, 3 * j + b, 0.0);
  };
  for (int i = 0; i < t.num_vertices; ++i) block(i, i);
  for (int e = 0; e < t.num_edges(); ++e)
    block(std::max(t.edges(0, e), t.edges(1, e)), std::min(t.edges(0, e), t.edges(1, e)));
  s->h.resize(3 * t.num_vertices, 3 * t.num_vertices);
  s->h.setFromTriplets(trip.begin(), trip.end());
  s->h.makeCompressed();
  s->problem.evaluate = [sc](const Eigen::VectorXd& xf, NewtonPoint& p) {
    const Topology& t = sc->mesh.topo;
    const Eigen::Map<const Eigen::Matrix3Xd> x(xf.data(), 3, t.num_vertices);
    p.value = 0;
    p.grad = Eigen::VectorXd::Zero(xf.size());
    for (int e = 0; e < t.num_edges(); ++e) {
      const int i = t.edges(0, e), j = t.edges(1, e);
      const Eigen::Vector3d d = x.col(i) - x.col(j);
      const double l = d.norm(), dl = l - sc->rest_length(e);
      p.value += 0.5 * sc->k * dl * dl;
      const Eigen::Vector3d f = sc->k * dl * d / l;
      p.grad.segment<3>(3 * i) += f;
      p.grad.segment<3>(3 * j) -= f;
    }
    const Eigen::Map<const Eigen::VectorXd> x0(sc->mesh.x.data(), xf.size());
    p.value += 0.5 * sc->tether * (xf - x0).squaredNorm();
    p.grad += sc->tether * (xf - x0);
    p.value -= sc->force * (xf(3 * sc->plus) - xf(3 * sc->minus));
    p.grad(3 * sc->plus) -= sc->force;
    p.grad(3 * sc->minus) += sc->force;
    p.c = Eigen::VectorXd::Constant(1, xf.squaredNorm() - sc->moment0);
    p.c_grad = 2.0 * xf;
    return true;
  };
  s->problem.hessian = [sc](const Eigen::VectorXd& xf,
                            const Eigen::VectorXd& lambda) -> const Eigen::SparseMatrix<double>& {
    const Topology& t = sc->mesh.topo;
    sc->h.coeffs().setZero();
    auto add = [&](int i, int j, const Eigen::Matrix3d& b) {  // lower triangle of (i, j)
      for (int a = 0; a < 3; ++a)
        for (int c = 0; c < 3; ++c)
          if (3 * i + a >= 3 * j + c) sc->h.coeffRef(3 * i + a, 3 * j + c) += b(a, c);
    };
    for (int e = 0; e < t.num_edges(); ++e) {
      const int i = t.edges(0, e), j = t.edges(1, e);
      const Eigen::Vector3d d = xf.segment<3>(3 * i) - xf.segment<3>(3 * j);
      const double l = d.norm(), r = sc->rest_length(e) / l;
      const Eigen::Vector3d n = d / l;
      const Eigen::Matrix3d b =
          sc->k * ((1.0 - r) * Eigen::Matrix3d::Identity() + r * n * n.transpose());
      add(i, i, b);
      add(j, j, b);
      add(std::max(i, j), std::min(i, j), -b);
    }
    for (int i = 0; i < t.num_vertices; ++i)
      add(i, i, (sc->tether + 2.0 * lambda(0)) * Eigen::Matrix3d::Identity());
    return sc->h;
  };
  s->problem.constraint_scale = Eigen::VectorXd::Constant(1, s->moment0);
  return s;
}

TEST(ReducedProblem, NewtonOnTheSymmetricStatesReachesTheFullEquilibrium) {
  auto s = spring_scene(252);
  const MeshSymmetry g = find_mirror_symmetry(s->mesh.x, s->mesh.topo);
  // The pulled pair: the load keeps the mirrors that map plus onto plus (sign +) or onto
  // minus (sign -).
  const MeshSymmetry kept = keep_invariant(g, {s->plus, s->minus}, {1.0, -1.0}, 0, 1e-12);
  ASSERT_GE(kept.order(), 2);
  auto red = std::make_shared<const SymmetryReduction>(make_symmetry_reduction(kept));
  ShiftedNewtonOptions o;
  o.force_tolerance = 1e-10;
  o.constraint_tolerance = 1e-12;
  o.max_iterations = 1000;
  ShiftedNewton full_solver(o), reduced_solver(o);
  Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(s->mesh.x.data(), s->mesh.x.size());
  Eigen::VectorXd lambda;
  const ShiftedNewtonResult rf = full_solver.solve(s->problem, x, lambda);
  ASSERT_EQ(rf.status, NewtonStatus::converged)
      << rf.iterations << " iterations, residual " << rf.residual;
  const NewtonProblem reduced = reduce_newton_problem(s->problem, red);
  Eigen::VectorXd q =
      symmetric_part(*red, Eigen::Map<const Eigen::VectorXd>(s->mesh.x.data(), s->mesh.x.size()));
  Eigen::VectorXd lq;
  const ShiftedNewtonResult rr = reduced_solver.solve(reduced, q, lq);
  ASSERT_EQ(rr.status, NewtonStatus::converged);
  EXPECT_LT(q.size() * 3, x.size() * 2);  // at least a third fewer unknowns
  EXPECT_LT((expand(*red, q) - x).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_NEAR(lq(0), lambda(0), 1e-8 * std::max(1.0, std::abs(lambda(0))));
  // The reported residual is the full problem's largest vertex force.
  NewtonPoint p;
  ASSERT_TRUE(s->problem.evaluate(expand(*red, q), p));
  const Eigen::VectorXd r = p.grad + p.c_grad * lq;
  EXPECT_NEAR(rr.residual, largest_block_norm(r, 3), 1e-12);
  EXPECT_LE(rr.residual, o.force_tolerance);
}

TEST(SymmetryStability, FindsTheSectorOfNegativeCurvatureAndOnlyIt) {
  // H = I - 2 P_c diag(orbit)^-1 P_c' is invariant under the group, -I on sector c and +I on
  // every other sector (the sectors are orthogonal): the check must fail there and only there.
  const TriMesh m = rest_mesh(252);
  const MeshSymmetry g = find_mirror_symmetry(m.x, m.topo);
  const std::vector<int> chars = nontrivial_characters(g);
  ASSERT_EQ(chars.size(), 3u);
  SymmetryStabilityCheck check(g, SparseCholeskyOptions{});
  EXPECT_EQ(check.sectors(), 3);
  const int n = 3 * m.topo.num_vertices;
  // The pattern of I plus every orbit's couplings, lower triangle.
  for (int c : chars) {
    const SymmetryReduction sector = make_symmetry_reduction(g, c);
    Eigen::MatrixXd p = dense_p(sector);
    Eigen::VectorXd inv_orbit(sector.reduced_size);
    for (int a = 0; a < sector.reduced_size; ++a)
      inv_orbit(a) = 1.0 / sector.orbit_size[sector.orbit_of_entry[a]];
    const Eigen::MatrixXd h =
        Eigen::MatrixXd::Identity(n, n) - 2.0 * p * inv_orbit.asDiagonal() * p.transpose();
    std::vector<Eigen::Triplet<double>> trip;
    for (int col = 0; col < n; ++col)
      for (int row = col; row < n; ++row)
        if (row == col || h(row, col) != 0.0) trip.emplace_back(row, col, h(row, col));
    Eigen::SparseMatrix<double> hs(n, n);
    hs.setFromTriplets(trip.begin(), trip.end());
    hs.makeCompressed();
    const SectorStability st = check.check(hs, 1e-8);
    EXPECT_FALSE(st.stable) << "sector " << c;
    EXPECT_EQ(st.unstable_character, c);
    // A push along the sector is a vector of that sector: its own symmetric part is zero.
    const Eigen::VectorXd d = check.sector_direction(c, 4);
    EXPECT_NEAR(d.norm(), 1.0, 1e-12);
    EXPECT_LT(symmetric_part(make_symmetry_reduction(g), d).norm(), 1e-12);
  }
  Eigen::SparseMatrix<double> id(n, n);
  id.setIdentity();
  id.makeCompressed();
  EXPECT_TRUE(check.check(id, 1e-8).stable);
}

}  // namespace
}  // namespace rbc
