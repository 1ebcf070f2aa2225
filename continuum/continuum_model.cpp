// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/continuum_model.hpp"

#include <omp.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/geometry.hpp"
#include "core/parallel.hpp"
#include "discrete/element_hessian.hpp"
#include "discrete/network_energy.hpp"

namespace rbc {

namespace {
// The energy of an infeasible (collapsed or overstretched) state, pN*um.
constexpr double kInfeasibleEnergy_pNum = std::numeric_limits<double>::infinity();
constexpr int kParallelHessianFaces = 256;

}  // namespace

namespace {
RestShapeOptions continuum_mesh_options(int elements) {
  if (elements < kMinContinuumElements || elements > kMaxContinuumElements)
    throw std::invalid_argument("element count " + std::to_string(elements) +
                                " is out of range; expected " +
                                std::to_string(kMinContinuumElements) + " to " +
                                std::to_string(kMaxContinuumElements) + " triangles");
  RestShapeOptions o;
  o.target_vertices = elements / 2 + 2;
  o.quality = RestMeshQuality::phi_minimised;
  return o;
}
}  // namespace

TriMesh make_continuum_mesh(int elements, const EvansFungShape& shape, MeshQualityReport* report) {
  RestShapeOptions o = continuum_mesh_options(elements);
  o.shape = shape;
  return make_rest_shape(o, report);
}

TriMesh make_continuum_mesh(int elements, unsigned rotation_seed,
                            TriangulationOrientation orientation, MeshQualityReport* report) {
  RestShapeOptions o = continuum_mesh_options(elements);
  o.rotation_seed = rotation_seed;
  o.orientation = orientation;
  return make_rest_shape(o, report);
}

IsotropicMembraneLaw scaled_law(const IsotropicMembraneLaw& law, double factor) {
  if (!(factor > 0) || !std::isfinite(factor))
    throw std::invalid_argument("law scale factor must be positive, got " + std::to_string(factor));
  IsotropicMembraneLaw out;
  out.name = law.name + " x " + std::to_string(factor);
  out.evaluate = [inner = law.evaluate, factor](double i1, double i2) {
    InvariantDerivatives d = inner(i1, i2);
    d.psi *= factor;
    d.d1 *= factor;
    d.d2 *= factor;
    d.d11 *= factor;
    d.d12 *= factor;
    d.d22 *= factor;
    return d;
  };
  return out;
}

void ContinuumParameters::validate() const {
  bending.validate();
  tweezers.validate();
}

ContinuumModel build_continuum_model(const TriMesh& rest, const IsotropicMembraneLaw& law,
                                     const ContinuumParameters& params) {
  params.validate();
  ContinuumModel m;
  m.topo = rest.topo;
  m.rest = rest.x;
  m.law = law;
  m.bending = params.bending;
  m.reference.reserve(rest.topo.num_faces());
  for (int f = 0; f < rest.topo.num_faces(); ++f) {
    const auto t = rest.topo.faces.col(f);
    m.reference.push_back(
        make_membrane_reference(rest.x.col(t(0)), rest.x.col(t(1)), rest.x.col(t(2))));
  }
  m.patch = select_tweezer_patch(rest.x, rest.topo, params.tweezers);
  m.area0_um2 = total_area(rest.x, rest.topo);
  m.volume0_um3 = enclosed_volume(rest.x, rest.topo);
  return m;
}

double membrane_energy(const ContinuumModel& model, const Positions& x, Positions* grad) {
  return assemble_parallel(
      model.num_elements(), grad,
      [&](int f, Positions& g) {
        const auto t = model.topo.faces.col(f);
        ElementGradient ge;
        const double e = membrane_element_energy(model.law, model.reference[f], x.col(t(0)),
                                                 x.col(t(1)), x.col(t(2)), grad ? &ge : nullptr);
        if (grad && std::isfinite(e))
          for (int k = 0; k < 3; ++k) g.col(t(k)) += ge.segment<3>(3 * k);
        return e;
      },
      kParallelHeavyElements);
}

void add_membrane_hessian(const ContinuumModel& model, const Positions& x, BlockHessian& h) {
  const int nf = model.num_elements();
  if (nf <= kChunkElements) {  // serial, without the per-element buffer
    Matrix9d he;
    for (int f = 0; f < nf; ++f) {
      const auto t = model.topo.faces.col(f);
      const double e = membrane_element_energy(model.law, model.reference[f], x.col(t(0)),
                                               x.col(t(1)), x.col(t(2)), nullptr, &he);
      if (!std::isfinite(e)) continue;  // callers only assemble at feasible states
      const int verts[3] = {t(0), t(1), t(2)};
      h.add_local<3>(verts, he);
    }
    return;
  }
  std::vector<Matrix9d> he(nf);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f) {
    const auto t = model.topo.faces.col(f);
    const double e = membrane_element_energy(model.law, model.reference[f], x.col(t(0)),
                                             x.col(t(1)), x.col(t(2)), nullptr, &he[f]);
    if (!std::isfinite(e)) he[f].setZero();  // callers only assemble at feasible states
  }
  for (int f = 0; f < nf; ++f) {
    const int verts[3] = {model.topo.faces(0, f), model.topo.faces(1, f), model.topo.faces(2, f)};
    h.add_local<3>(verts, he[f]);
  }
}

double continuum_energy(const ContinuumModel& model, const Positions& x, double force_pN,
                        Positions* grad, ContinuumEnergyParts* parts) {
  if (grad) grad->setZero(3, x.cols());
  // The shared geometry (face normals and areas, edge lengths, hinge angles) serves the
  // feasibility check and the bending term's value and chain-rule gradient.
  const NetworkGeometry geo = network_geometry(x, model.topo);
  // Feasibility first: a collapsed element makes every term meaningless.
  const int nf = model.num_elements();
  for (int f = 0; f < nf; ++f)
    if (!(geo.face_area[f] >= kCollapsedElementRatio * model.reference[f].area_um2))
      return kInfeasibleEnergy_pNum;
  ContinuumEnergyParts p;
  if (model.inplane()) {
    p.inplane = membrane_energy(model, x, grad);
    if (!std::isfinite(p.inplane)) return kInfeasibleEnergy_pNum;
  }
  GeometricGradient coef;
  if (grad) coef = GeometricGradient::zero(model.topo, grad);
  p.bending = juelicher_bending_energy(model.topo, model.bending, geo, grad ? &coef : nullptr);
  if (grad) assemble_geometric_gradient(x, model.topo, geo, coef, *grad);
  p.tweezers = tweezers_energy(model.patch, force_pN, x, model.rest, grad);
  if (parts) *parts = p;
  return p.total();
}

void add_continuum_hessian(const ContinuumModel& model, const Positions& x, BlockHessian& h) {
  if (model.inplane()) add_membrane_hessian(model, x, h);
  add_juelicher_hessian(x, model.topo, model.bending, h);
}

ConstraintValues evaluate_constraints(const Positions& x, const Topology& topo) {
  ConstraintValues c;
  c.grad_area.setZero(3, x.cols());
  c.grad_volume.setZero(3, x.cols());
  c.area_um2 = assemble_parallel(topo.num_faces(), &c.grad_area, [&](int f, Positions& g) {
    const auto t = topo.faces.col(f);
    Eigen::Matrix3d ga;
    const double a = triangle_area(x.col(t(0)), x.col(t(1)), x.col(t(2)), &ga);
    for (int k = 0; k < 3; ++k) g.col(t(k)) += ga.col(k);
    return a;
  });
  c.volume_um3 = assemble_parallel(topo.num_faces(), &c.grad_volume, [&](int f, Positions& g) {
    const auto t = topo.faces.col(f);
    Eigen::Matrix3d gv;
    const double v = tetra_volume(x.col(t(0)), x.col(t(1)), x.col(t(2)), &gv);
    for (int k = 0; k < 3; ++k) g.col(t(k)) += gv.col(k);
    return v;
  });
  return c;
}

void add_constraint_hessian(const Positions& x, const Topology& topo, double area_coef,
                            double volume_coef, BlockHessian& h) {
  const int nf = topo.num_faces();
  if (nf <= kChunkElements) {  // serial, without the per-face buffer
    Matrix9d ha;
    for (int f = 0; f < nf; ++f) {
      const auto t = topo.faces.col(f);
      triangle_area_hessian(x.col(t(0)), x.col(t(1)), x.col(t(2)), nullptr, &ha);
      const int verts[3] = {t(0), t(1), t(2)};
      h.add_local<3>(verts, Matrix9d(area_coef * ha +
                                     volume_coef * tetra_volume_hessian(x.col(t(0)), x.col(t(1)),
                                                                        x.col(t(2)))));
    }
    return;
  }
  std::vector<Matrix9d> hf(nf);
#pragma omp parallel for schedule(static)
  for (int f = 0; f < nf; ++f) {
    const auto t = topo.faces.col(f);
    Matrix9d ha;
    triangle_area_hessian(x.col(t(0)), x.col(t(1)), x.col(t(2)), nullptr, &ha);
    hf[f] =
        area_coef * ha + volume_coef * tetra_volume_hessian(x.col(t(0)), x.col(t(1)), x.col(t(2)));
  }
  for (int f = 0; f < nf; ++f) {
    const int verts[3] = {topo.faces(0, f), topo.faces(1, f), topo.faces(2, f)};
    h.add_local<3>(verts, hf[f]);
  }
}

void lagrangian_face_hessian(const ContinuumModel& model, const Positions& x,
                             const JuelicherHessianTerms& terms, int f, double area_coef,
                             double volume_coef, Matrix9d& hf) {
  // Membrane element + (Psi_1 + area_coef + Juelicher beta_f) d2A + volume_coef d2V, with d2A
  // evaluated once.
  const Topology& t = model.topo;
  const auto v = t.faces.col(f);
  const Vec3 a = x.col(v(0)), b = x.col(v(1)), c = x.col(v(2));
  double coef = terms.add_face_coef(t, f, area_coef);
  hf.setZero();
  if (model.inplane()) {
    double psi1 = 0.0;
    if (std::isfinite(
            membrane_element_hessian_parts(model.law, model.reference[f], a, b, c, hf, psi1)))
      coef += psi1;
    else
      hf.setZero();  // callers only assemble at feasible states
  }
  Matrix9d d2a;
  triangle_area_hessian(a, b, c, nullptr, &d2a);
  hf += coef * d2a;
  if (volume_coef != 0.0) hf += volume_coef * tetra_volume_hessian(a, b, c);
}

void lagrangian_hinge_hessian(const ContinuumModel& model, const Positions& x,
                              const JuelicherHessianTerms& terms, int e, Matrix12d& he) {
  const Topology& t = model.topo;
  hinge_length_angle_hessian(x.col(t.edges(0, e)), x.col(t.edges(1, e)),
                             x.col(t.edge_opposite(0, e)), x.col(t.edge_opposite(1, e)), nullptr,
                             &he);
  he *= terms.hinge_coef(t, e);
}

void add_lagrangian_hessian(const ContinuumModel& model, const Positions& x, double area_coef,
                            double volume_coef, BlockHessian& h) {
  const Topology& t = model.topo;
  const int nv = t.num_vertices, ne = t.num_edges(), nf = t.num_faces();
  // Element matrices on the threads from a few hundred faces on (the assembly is most of a
  // Newton iteration with the Krylov correction); each block's terms are added in the same
  // order on either path, so the matrix does not depend on the thread count.
  const bool parallel = nf > kParallelHessianFaces && omp_get_max_threads() > 1;
  const JuelicherHessianTerms terms = juelicher_hessian_terms(x, t, model.bending);
  auto face = [&](int f, Matrix9d& hf) {
    lagrangian_face_hessian(model, x, terms, f, area_coef, volume_coef, hf);
  };
  auto hinge = [&](int e, Matrix12d& he) { lagrangian_hinge_hessian(model, x, terms, e, he); };
  const VertexStars& stars = h.stars();
  if (!parallel) {  // serial, without the per-element buffers
    Matrix9d hf;
    for (int f = 0; f < nf; ++f) {
      face(f, hf);
      h.add_face(f, hf);
    }
    Matrix12d he;
    for (int e = 0; e < ne; ++e) {
      hinge(e, he);
      h.add_hinge(e, he);
    }
    // Rank-one Juelicher cell terms (kappa/A_v) u_v u_v^T over each closed star.
    std::vector<double> u;
    for (int v = 0; v < nv; ++v) {
      u.resize(3 * static_cast<size_t>(stars.size(v)));
      terms.cell_gradient(t, stars, v, u.data());
      h.add_star_outer(v, u.data(), terms.cell_weight(v));
    }
    return;
  }
  // Element matrices on the threads into the Hessian's kept buffers; then every thread adds
  // all of them into its own share of the stored blocks, in the serial order (bit-identical
  // to the serial path, whatever the thread count).
  BlockHessian::ElementBuffers& buf = h.element_buffers();
#pragma omp parallel
  {
#pragma omp for schedule(static) nowait
    for (int f = 0; f < nf; ++f) face(f, buf.faces[f]);
#pragma omp for schedule(static) nowait
    for (int e = 0; e < ne; ++e) hinge(e, buf.hinges[e]);
#pragma omp for schedule(static)
    for (int v = 0; v < nv; ++v) {
      terms.cell_gradient(t, stars, v, buf.star_vectors.data() + h.star_vector_offset(v));
      buf.star_coefs[v] = terms.cell_weight(v);
    }
    h.add_elements_share(buf, omp_get_thread_num(), omp_get_num_threads());
  }
}

ElementFields element_fields(const ContinuumModel& model, const Positions& x) {
  const int nf = model.num_elements();
  ElementFields out;
  out.i1.resize(nf);
  out.i2.resize(nf);
  out.tension_max_pN_per_um.setZero(nf);
  out.tension_min_pN_per_um.setZero(nf);
  for (int f = 0; f < nf; ++f) {
    const auto t = model.topo.faces.col(f);
    const SurfaceInvariants inv =
        surface_invariants(model.reference[f], x.col(t(0)), x.col(t(1)), x.col(t(2)));
    out.i1(f) = inv.i1;
    out.i2(f) = inv.i2;
    if (model.inplane()) {
      const PrincipalTensions pt =
          principal_tensions(model.law, model.reference[f], x.col(t(0)), x.col(t(1)), x.col(t(2)));
      out.tension_max_pN_per_um(f) = pt.t1;
      out.tension_min_pN_per_um(f) = pt.t2;
    }
  }
  return out;
}

}  // namespace rbc
