#include "discrete/bending_energy.hpp"

#include <cmath>
#include <stdexcept>
#include <vector>

#include "core/geometry.hpp"
#include "core/parallel.hpp"
#include "core/units.hpp"
#include "core/validation.hpp"

namespace rbc {

void BendingParameters::validate() const {
  require_finite_in_range("bending rigidity kappa", "J", kappa_pNum / units::pNum_per_J, 0.0,
                          kMaxKappa_J, Ends::closed_closed);
  require_finite_in_range("spontaneous curvature H0", "1/um", h0_per_um,
                          -kMaxSpontaneousCurvature_per_um, kMaxSpontaneousCurvature_per_um,
                          Ends::closed_closed);
}

std::string to_string(BendingModel m) {
  return m == BendingModel::juelicher ? "juelicher" : "dihedral";
}

BendingModel bending_model_from_string(const std::string& name) {
  if (name == "juelicher") return BendingModel::juelicher;
  if (name == "dihedral") return BendingModel::dihedral;
  throw std::invalid_argument("bending model '" + name + "' is not one of juelicher, dihedral");
}

double dihedral_stiffness_pNum(double kappa_pNum, DihedralMapping mapping) {
  return mapping == DihedralMapping::sphere_matched ? 2.0 * units::sqrt3 * kappa_pNum
                                                    : 2.0 * kappa_pNum / units::sqrt3;
}

double hinge_length_angle(const Positions& x, const Topology& topo, int e,
                          Eigen::Matrix<double, 3, 4>* grad) {
  const int a = topo.edges(0, e), b = topo.edges(1, e);
  const int c = topo.edge_opposite(0, e), d = topo.edge_opposite(1, e);
  Eigen::Matrix<double, 3, 4> gt;
  const double theta = dihedral_angle(x.col(a), x.col(b), x.col(c), x.col(d), grad ? &gt : nullptr);
  const Eigen::Vector3d ab = x.col(b) - x.col(a);
  const double len = ab.norm();
  if (grad) {
    *grad = len * gt;
    grad->col(1) += theta * ab / len;
    grad->col(0) -= theta * ab / len;
  }
  return len * theta;
}

double juelicher_bending_energy(const Positions& x, const Topology& topo,
                                const BendingParameters& p, Positions* grad) {
  const int nv = topo.num_vertices, ne = topo.num_edges(), nf = topo.num_faces();
  std::vector<double> lt(ne), af(nf), h(nv);
#pragma omp parallel for schedule(static)
  for (int e = 0; e < ne; ++e) lt[e] = hinge_length_angle(x, topo, e);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f) {
    const auto& t = topo.faces.col(f);
    af[f] = triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)));
  }
  double energy = 0.0;
#pragma omp parallel for reduction(+ : energy) schedule(static)
  for (int v = 0; v < nv; ++v) {
    double m = 0, a = 0;
    for (const int* e = topo.vertex_edges.begin(v); e != topo.vertex_edges.end(v); ++e) m += lt[*e];
    for (const int* f = topo.vertex_faces.begin(v); f != topo.vertex_faces.end(v); ++f) a += af[*f];
    m *= 0.5;
    a /= 3.0;
    h[v] = (m - p.h0_per_um * a) / a;  // (M - H0 A)/A: the vertex's H - H0
    energy += 0.5 * p.kappa_pNum * h[v] * h[v] * a;
  }
  if (!grad) return energy;
  // dE = kappa sum_i h_i (dM_i - H0 dA_i) - kappa/2 h_i^2 dA_i, with dM_i = 1/2 sum d(L theta)
  // over the vertex's edges and dA_i = 1/3 sum dA_f over its faces.
  assemble_parallel(ne, grad, [&](int e, Positions& g) {
    Eigen::Matrix<double, 3, 4> gl;
    hinge_length_angle(x, topo, e, &gl);
    const double coef = 0.5 * p.kappa_pNum * (h[topo.edges(0, e)] + h[topo.edges(1, e)]);
    g.col(topo.edges(0, e)) += coef * gl.col(0);
    g.col(topo.edges(1, e)) += coef * gl.col(1);
    g.col(topo.edge_opposite(0, e)) += coef * gl.col(2);
    g.col(topo.edge_opposite(1, e)) += coef * gl.col(3);
    return 0.0;
  });
  assemble_parallel(nf, grad, [&](int f, Positions& g) {
    const auto& t = topo.faces.col(f);
    Eigen::Matrix3d ga;
    triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)), &ga);
    double coef = 0;
    for (int k = 0; k < 3; ++k)
      coef -= p.kappa_pNum * (p.h0_per_um * h[t(k)] + 0.5 * h[t(k)] * h[t(k)]) / 3.0;
    for (int k = 0; k < 3; ++k) g.col(t(k)) += coef * ga.col(k);
    return 0.0;
  });
  return energy;
}

double juelicher_vertex_energy(const Positions& x, const Topology& topo, const BendingParameters& p,
                               int v) {
  double lt = 0, area = 0;
  for (const int* e = topo.vertex_edges.begin(v); e != topo.vertex_edges.end(v); ++e)
    lt += hinge_length_angle(x, topo, *e);
  for (const int* f = topo.vertex_faces.begin(v); f != topo.vertex_faces.end(v); ++f) {
    const auto& t = topo.faces.col(*f);
    area += triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)));
  }
  return juelicher_cell_energy(p, lt, area);
}

double dihedral_hinge_energy(const Positions& x, const Topology& topo, double kb, double theta0,
                             int e, Eigen::Matrix<double, 3, 4>* grad) {
  const int a = topo.edges(0, e), b = topo.edges(1, e);
  const int c = topo.edge_opposite(0, e), d = topo.edge_opposite(1, e);
  const double theta = dihedral_angle(x.col(a), x.col(b), x.col(c), x.col(d), grad);
  if (grad) *grad *= kb * std::sin(theta - theta0);  // dE/dtheta dtheta/dx
  return kb * (1.0 - std::cos(theta - theta0));
}

double dihedral_bending_energy(const Positions& x, const Topology& topo, double kb, double theta0,
                               Positions* grad) {
  return assemble_parallel(topo.num_edges(), grad, [&](int e, Positions& g) {
    Eigen::Matrix<double, 3, 4> gh;
    const double energy = dihedral_hinge_energy(x, topo, kb, theta0, e, grad ? &gh : nullptr);
    if (grad) {
      g.col(topo.edges(0, e)) += gh.col(0);
      g.col(topo.edges(1, e)) += gh.col(1);
      g.col(topo.edge_opposite(0, e)) += gh.col(2);
      g.col(topo.edge_opposite(1, e)) += gh.col(3);
    }
    return energy;
  });
}

}  // namespace rbc
