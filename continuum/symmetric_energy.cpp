// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/symmetric_energy.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "continuum/membrane_element.hpp"
#include "core/geometry.hpp"
#include "discrete/bending_energy.hpp"
#include "discrete/tweezers.hpp"

namespace rbc {

namespace {
/// continuum_energy's value for an infeasible state.
constexpr double kInfeasible_pNum = std::numeric_limits<double>::infinity();
}  // namespace

SymmetricContinuumEnergy::SymmetricContinuumEnergy(const ContinuumModel& model,
                                                   const ReducedLagrangianHessian& orbits)
    : model_(&model), faces_(orbits.face_representatives()), cells_(orbits.star_representatives()) {
  const Topology& t = model.topo;
  weight_.assign(static_cast<size_t>(t.num_vertices), 0.0);
  std::vector<char> edge_used(static_cast<size_t>(t.num_edges()), 0);
  std::vector<char> face_used(static_cast<size_t>(t.num_faces()), 0);
  for (const auto& c : cells_) {
    weight_[static_cast<size_t>(c.id)] = c.weight;
    for (const int* e = t.vertex_edges.begin(c.id); e != t.vertex_edges.end(c.id); ++e)
      edge_used[static_cast<size_t>(*e)] = 1;
    for (const int* f = t.vertex_faces.begin(c.id); f != t.vertex_faces.end(c.id); ++f)
      face_used[static_cast<size_t>(*f)] = 1;
  }
  for (int e = 0; e < t.num_edges(); ++e)
    if (edge_used[static_cast<size_t>(e)]) cell_edges_.push_back(e);
  for (int f = 0; f < t.num_faces(); ++f)
    if (face_used[static_cast<size_t>(f)]) cell_faces_.push_back(f);
  lt_.assign(static_cast<size_t>(t.num_edges()), 0.0);
  af_.assign(static_cast<size_t>(t.num_faces()), 0.0);
  h_.assign(static_cast<size_t>(t.num_vertices), 0.0);
  glt_.resize(static_cast<size_t>(t.num_edges()));
  gaf_.resize(static_cast<size_t>(t.num_faces()));
}

double SymmetricContinuumEnergy::evaluate(const Positions& x, double force_pN, Positions& grad,
                                          ConstraintValues& c) {
  const ContinuumModel& m = *model_;
  const Topology& t = m.topo;
  const auto n = x.cols();
  grad.setZero(3, n);
  c.grad_area.setZero(3, n);
  c.grad_volume.setZero(3, n);
  c.area_um2 = c.volume_um3 = 0.0;
  double energy = 0.0;
  // Faces: feasibility, in-plane energy, area and volume.
  for (const auto& [f, w] : faces_) {
    const auto v = t.faces.col(f);
    Eigen::Matrix3d ga, gv;
    const double a = triangle_area(x.col(v(0)), x.col(v(1)), x.col(v(2)), &ga);
    if (!(a >= kCollapsedElementRatio * m.reference[static_cast<size_t>(f)].area_um2))
      return kInfeasible_pNum;
    const double vol = tetra_volume(x.col(v(0)), x.col(v(1)), x.col(v(2)), &gv);
    c.area_um2 += w * a;
    c.volume_um3 += w * vol;
    for (int k = 0; k < 3; ++k) {
      c.grad_area.col(v(k)) += w * ga.col(k);
      c.grad_volume.col(v(k)) += w * gv.col(k);
    }
    if (m.inplane()) {
      ElementGradient ge;
      const double e = membrane_element_energy(m.law, m.reference[static_cast<size_t>(f)],
                                               x.col(v(0)), x.col(v(1)), x.col(v(2)), &ge);
      if (!std::isfinite(e)) return kInfeasible_pNum;
      energy += w * e;
      for (int k = 0; k < 3; ++k) grad.col(v(k)) += w * ge.segment<3>(3 * k);
    }
  }
  // Juelicher cells of the representative vertices: E = sum_v w_v E_v; a hinge's coefficient
  // dE/d(L theta) and a face's dE/dA take each end's or corner's cell with its weight (0 for
  // a vertex that is no representative), as the full sums take every cell with weight 1.
  const BendingParameters& p = m.bending;
  for (const int e : cell_edges_)
    lt_[static_cast<size_t>(e)] = hinge_length_angle(x, t, e, &glt_[static_cast<size_t>(e)]);
  for (const int f : cell_faces_) {
    const auto v = t.faces.col(f);
    af_[static_cast<size_t>(f)] =
        triangle_area(x.col(v(0)), x.col(v(1)), x.col(v(2)), &gaf_[static_cast<size_t>(f)]);
  }
  for (const auto& [v, w] : cells_) {
    const JuelicherCell cell = juelicher_vertex_cell(
        t, p, v, [&](int e) { return lt_[static_cast<size_t>(e)]; },
        [&](int f) { return af_[static_cast<size_t>(f)]; });
    energy += w * cell.energy_pNum;
    h_[static_cast<size_t>(v)] = cell.h_per_um;
  }
  const auto wh = [&](int v) {
    return weight_[static_cast<size_t>(v)] * h_[static_cast<size_t>(v)];
  };
  for (const int e : cell_edges_) {
    // Linear in the two cells' h: each end weighted.
    const double coef = juelicher_hinge_coef(p, wh(t.edges(0, e)), wh(t.edges(1, e)));
    const Eigen::Matrix<double, 3, 4>& g = glt_[static_cast<size_t>(e)];
    grad.col(t.edges(0, e)) += coef * g.col(0);
    grad.col(t.edges(1, e)) += coef * g.col(1);
    grad.col(t.edge_opposite(0, e)) += coef * g.col(2);
    grad.col(t.edge_opposite(1, e)) += coef * g.col(3);
  }
  for (const int f : cell_faces_) {
    const auto v = t.faces.col(f);
    const double hf[3] = {h_[static_cast<size_t>(v(0))], h_[static_cast<size_t>(v(1))],
                          h_[static_cast<size_t>(v(2))]};
    const double wf[3] = {weight_[static_cast<size_t>(v(0))], weight_[static_cast<size_t>(v(1))],
                          weight_[static_cast<size_t>(v(2))]};
    const double coef = juelicher_face_coef(p, hf, wf);
    for (int k = 0; k < 3; ++k) grad.col(v(k)) += coef * gaf_[static_cast<size_t>(f)].col(k);
  }
  // The tweezers work, whole (its gradient is symmetric: its reduction is the reduced one).
  energy += tweezers_energy(m.patch, force_pN, x, m.rest, &grad);
  return energy;
}

}  // namespace rbc
