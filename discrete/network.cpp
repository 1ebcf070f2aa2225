// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/network.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/geometry.hpp"
#include "core/multiversion.hpp"
#include "core/parallel.hpp"
#include "discrete/link_energy.hpp"
#include "discrete/network_energy.hpp"

namespace rbc {

void NetworkParameters::validate() const {
  wlc.validate();
  steric.validate();
  bending.validate();
  constraints.validate();
  tweezers.validate();
}

Network build_network(const TriMesh& mesh, const NetworkParameters& p) {
  p.validate();
  Network net;
  net.topo = mesh.topo;
  net.rest = mesh.x;
  net.lbar_um = edge_lengths(mesh.x, mesh.topo);
  net.abar_um2 = face_areas(mesh.x, mesh.topo);
  if (net.abar_um2.minCoeff() <= 0)
    throw std::invalid_argument("rest mesh has a face of zero area");
  net.wlc = make_wlc_density(p.wlc, p.expansion);
  net.steric = p.steric;
  net.steric_C_pN_per_um = steric_constant(net.wlc, p.steric);
  net.bending = p.bending;
  net.bending_model = p.bending_model;
  net.dihedral_kb_pNum = dihedral_stiffness_pNum(p.bending.kappa_pNum, p.dihedral_mapping);
  net.constraints = p.constraints;
  net.area0_um2 = total_area(mesh.x, mesh.topo);
  net.volume0_um3 = enclosed_volume(mesh.x, mesh.topo);
  net.patch = select_tweezer_patch(mesh.x, mesh.topo, p.tweezers);
  return net;
}

namespace {

double inplane_energy(const Network& net, const Positions& x, Positions* grad, double* links,
                      double* steric) {
  const Topology& t = net.topo;
  const double inf = std::numeric_limits<double>::infinity();
  *links = assemble_parallel(t.num_edges(), grad, [&](int e, Positions& g) {
    const int a = t.edges(0, e), b = t.edges(1, e);
    Eigen::Vector3d gb;
    const double v = link_energy(net.wlc, net.lbar_um(e), x.col(a), x.col(b), grad ? &gb : nullptr);
    if (grad && v < inf) {
      g.col(b) += gb;
      g.col(a) -= gb;
    }
    return v;
  });
  if (!(*links < inf)) return inf;
  bool collapsed = false;
  *steric = assemble_parallel(t.num_faces(), grad, [&](int f, Positions& g) {
    const auto& c = t.faces.col(f);
    Eigen::Matrix3d gf;
    const double ratio = triangle_area(x.col(c(0)), x.col(c(1)), x.col(c(2))) / net.abar_um2(f);
    if (ratio < kCollapsedFaceRatio) {
      collapsed = true;  // benign race: every writer writes true
      return 0.0;
    }
    const double v =
        steric_face_energy(net.steric_C_pN_per_um, net.steric, net.abar_um2(f), x.col(c(0)),
                           x.col(c(1)), x.col(c(2)), grad ? &gf : nullptr);
    if (grad)
      for (int k = 0; k < 3; ++k) g.col(c(k)) += gf.col(k);
    return v;
  });
  return collapsed ? inf : *links + *steric;
}

/// Links [begin, end) of inplane_energy from the shared geometry: their energy (+infinity at or
/// past Lmax), dE_e/dL_e added into dl (pN) unless null. Compiled for x86-64-v3 too. The full law
/// runs in blocks: the densities of a block in a loop the compiler vectorises (no branches in
/// evaluate_full), then its energies summed in order (the same sums as one loop).
RBC_HOT_CLONES double links_from_geometry(const WlcDensity& wlc, const double* lbar_um,
                                          const double* length_um, int begin, int end, double* dl) {
  constexpr double sqrt3 = 1.73205080756887729353;
  constexpr double inf = std::numeric_limits<double>::infinity();
  double s = 0;
  if (wlc.expansion != WlcExpansion::full) {
    for (int e = begin; e < end; ++e) {
      const double len = length_um[e], lbar2 = lbar_um[e] * lbar_um[e];
      const DensityValue v = evaluate_stretch(wlc, len / lbar_um[e], 1);
      if (!(v.v < inf)) return inf;  // not a number (positions)
      s += 0.5 * sqrt3 * lbar2 * v.v;
      if (dl) dl[e] += sqrt3 * v.dv * len;
    }
    return s;
  }
  constexpr int kBlock = 128;
  double energy[kBlock], force[kBlock];
  for (int b0 = begin; b0 < end; b0 += kBlock) {
    const int n = std::min(kBlock, end - b0);
    for (int i = 0; i < n; ++i) {
      const double len = length_um[b0 + i], lbar = lbar_um[b0 + i];
      const DensityValue v = detail::evaluate_full(wlc, wlc.x0 * (len / lbar), 1);  // stretch
      energy[i] = 0.5 * sqrt3 * (lbar * lbar) * v.v;
      force[i] = sqrt3 * v.dv * len;
    }
    for (int i = 0; i < n; ++i) {
      if (!(energy[i] < inf)) return inf;
      s += energy[i];
    }
    if (dl)
      for (int i = 0; i < n; ++i) dl[b0 + i] += force[i];
  }
  return s;
}

/// Faces [begin, end) of inplane_energy from the shared geometry: their steric energy, dE_f/dA_f
/// added into da unless null; collapsed (and the sum so far returned) at a face below
/// kCollapsedFaceRatio of its rest area. Compiled for x86-64-v3 too. The paper's q = 1 runs in
/// blocks, as links_from_geometry (the densities vectorised, the energies summed in order).
RBC_HOT_CLONES double faces_from_geometry(double C, const StericParameters& steric,
                                          const double* abar_um2, const double* area_um2, int begin,
                                          int end, double* da, bool& collapsed) {
  double s = 0;
  if (steric.q != 1.0) {
    for (int f = begin; f < end; ++f) {
      const double abar = abar_um2[f], ratio = area_um2[f] / abar;
      if (ratio < kCollapsedFaceRatio) {
        collapsed = true;
        break;
      }
      const StericDensity d = steric_density(C, steric, ratio, 1);
      s += abar * d.v;
      if (da) da[f] += d.dv;
    }
    return s;
  }
  StericParameters linear = steric;
  linear.q = 1.0;  // a constant here: steric_density's q = 1 path, without the pow
  constexpr int kBlock = 128;
  double ratio[kBlock], energy[kBlock], slope[kBlock];
  for (int b0 = begin; b0 < end; b0 += kBlock) {
    const int n = std::min(kBlock, end - b0);
    for (int i = 0; i < n; ++i) {
      const double abar = abar_um2[b0 + i];
      ratio[i] = area_um2[b0 + i] / abar;
      const StericDensity d = steric_density(C, linear, ratio[i], 1);
      energy[i] = abar * d.v;
      slope[i] = d.dv;
    }
    for (int i = 0; i < n; ++i) {
      if (ratio[i] < kCollapsedFaceRatio) {
        collapsed = true;
        return s;
      }
      s += energy[i];
    }
    if (da)
      for (int i = 0; i < n; ++i) da[b0 + i] += slope[i];
  }
  return s;
}

/// inplane_energy from the shared geometry: dE_e/dL_e = sqrt3 V'(z) L_e (link_energy.hpp),
/// dE_f/dA_f = s'(J) (steric_energy.hpp).
double inplane_energy(const Network& net, const NetworkGeometry& geo, GeometricGradient* grad,
                      double* links, double* steric) {
  const Topology& t = net.topo;
  const double inf = std::numeric_limits<double>::infinity();
  const int ne = t.num_edges(), nf = t.num_faces();
  double partial[kMaxChunks] = {0, 0, 0, 0}, face_partial[kMaxChunks] = {0, 0, 0, 0};
  bool collapsed[kMaxChunks] = {false, false, false, false};
  double* dl = grad ? grad->edge_length.data() : nullptr;
  double* da = grad ? grad->face_area.data() : nullptr;
  const auto links_chunk = [&](int c, int begin, int end) {
    partial[c] =
        links_from_geometry(net.wlc, net.lbar_um.data(), geo.edge_length.data(), begin, end, dl);
  };
  const auto faces_chunk = [&](int c, int begin, int end) {
    face_partial[c] = faces_from_geometry(net.steric_C_pN_per_um, net.steric, net.abar_um2.data(),
                                          geo.face_area.data(), begin, end, da, collapsed[c]);
  };
  for_each_chunk_pair(ne, links_chunk, nf, faces_chunk, Then::independent);
  *links = 0;
  for (int c = 0; c < assembly_chunks(ne); ++c) *links += partial[c];
  if (!(*links < inf)) return inf;
  *steric = 0;
  for (int c = 0; c < assembly_chunks(nf); ++c) {
    if (collapsed[c]) return inf;
    *steric += face_partial[c];
  }
  return *links + *steric;
}

}  // namespace

namespace {

/// The production list for a bending model (built once; the terms read everything from the
/// Network they are given, so one list serves every network).
std::vector<NetworkTerm> make_production_terms(BendingModel model) {
  std::vector<NetworkTerm> t;
  t.push_back({"in-plane",
               [](const Network& n, const Positions& x, const LoadState&, Positions* grad,
                  EnergyBreakdown& e) { return inplane_energy(n, x, grad, &e.links, &e.steric); },
               [](const Network& n, const Positions&, const NetworkGeometry& geo, const LoadState&,
                  GeometricGradient* grad,
                  EnergyBreakdown& e) { return inplane_energy(n, geo, grad, &e.links, &e.steric); },
               TermKind::in_plane,
               {}});
  if (model == BendingModel::juelicher)
    t.push_back({"bending (juelicher)",
                 [](const Network& n, const Positions& x, const LoadState&, Positions* grad,
                    EnergyBreakdown& e) {
                   return e.bending = juelicher_bending_energy(x, n.topo, n.bending, grad);
                 },
                 [](const Network& n, const Positions&, const NetworkGeometry& geo,
                    const LoadState&, GeometricGradient* grad, EnergyBreakdown& e) {
                   return e.bending = juelicher_bending_energy(n.topo, n.bending, geo, grad);
                 },
                 TermKind::juelicher_bending,
                 {}});
  else
    t.push_back({"bending (dihedral)",
                 [](const Network& n, const Positions& x, const LoadState&, Positions* grad,
                    EnergyBreakdown& e) {
                   return e.bending =
                              dihedral_bending_energy(x, n.topo, n.dihedral_kb_pNum, 0.0, grad);
                 },
                 {},
                 TermKind::dihedral_bending,
                 {}});
  t.push_back({"area/volume",
               [](const Network& n, const Positions& x, const LoadState& load, Positions* grad,
                  EnergyBreakdown& e) {
                 ConstraintParameters penalty = n.constraints;
                 penalty.area_stiffness_pN_per_um3 *= load.stiffness_scale;
                 penalty.volume_stiffness_pN_per_um5 *= load.stiffness_scale;
                 return e.constraints = constraint_energy(x, n.topo, n.area0_um2, n.volume0_um3,
                                                          penalty, load.multipliers, grad);
               },
               [](const Network& n, const Positions&, const NetworkGeometry& geo,
                  const LoadState& load, GeometricGradient* grad, EnergyBreakdown& e) {
                 ConstraintParameters penalty = n.constraints;
                 penalty.area_stiffness_pN_per_um3 *= load.stiffness_scale;
                 penalty.volume_stiffness_pN_per_um5 *= load.stiffness_scale;
                 return e.constraints = constraint_energy(geo, n.area0_um2, n.volume0_um3, penalty,
                                                          load.multipliers, grad);
               },
               TermKind::area_volume,
               {}});
  t.push_back({"tweezers",
               [](const Network& n, const Positions& x, const LoadState& load, Positions* grad,
                  EnergyBreakdown& e) {
                 return e.tweezers = tweezers_energy(n.patch, load.force_pN, x, n.rest, grad);
               },
               [](const Network& n, const Positions& x, const NetworkGeometry&,
                  const LoadState& load, GeometricGradient* grad, EnergyBreakdown& e) {
                 return e.tweezers = tweezers_energy(n.patch, load.force_pN, x, n.rest,
                                                     grad ? grad->direct : nullptr);
               },
               TermKind::tweezers,
               {}});
  return t;
}

const std::vector<NetworkTerm>& production_terms(BendingModel model) {
  static const std::vector<NetworkTerm> juelicher = make_production_terms(BendingModel::juelicher);
  static const std::vector<NetworkTerm> dihedral = make_production_terms(BendingModel::dihedral);
  return model == BendingModel::juelicher ? juelicher : dihedral;
}

}  // namespace

std::vector<NetworkTerm> network_terms(const Network& net) {
  return production_terms(net.bending_model);
}

const std::vector<NetworkTerm>& model_terms(const Network& net) {
  return net.terms.empty() ? production_terms(net.bending_model) : net.terms;
}

bool has_term(const Network& net, TermKind kind) {
  for (const NetworkTerm& t : model_terms(net))
    if (t.kind == kind) return true;
  return false;
}

double sum_network_terms(const std::vector<NetworkTerm>& terms, const Network& net,
                         const Positions& x, const LoadState& load, Positions* grad,
                         EnergyBreakdown* parts) {
  EnergyBreakdown e;
  if (grad) grad->setZero(3, x.cols());
  const bool shared = std::all_of(terms.begin(), terms.end(),
                                  [](const NetworkTerm& t) { return bool(t.from_geometry); });
  if (shared && !terms.empty()) {
    const NetworkGeometry geo = network_geometry(x, net.topo);
    GeometricGradient coef;
    if (grad) coef = GeometricGradient::zero(net.topo, grad);
    for (const NetworkTerm& term : terms)
      if (!(term.from_geometry(net, x, geo, load, grad ? &coef : nullptr, e) <
            std::numeric_limits<double>::infinity()))
        return std::numeric_limits<double>::infinity();
    if (grad) assemble_geometric_gradient(x, net.topo, geo, coef, *grad);
    if (parts) *parts = e;
    return e.total();
  }
  for (const NetworkTerm& term : terms)
    if (!(term.energy(net, x, load, grad, e) < std::numeric_limits<double>::infinity()))
      return std::numeric_limits<double>::infinity();
  if (parts) *parts = e;
  return e.total();
}

double network_energy(const Network& net, const Positions& x, const LoadState& load,
                      Positions* grad, EnergyBreakdown* parts) {
  return sum_network_terms(model_terms(net), net, x, load, grad, parts);
}

double largest_rest_inplane_force_pN(const Network& net) {
  Positions g = Positions::Zero(3, net.rest.cols());
  double links = 0, steric = 0;
  inplane_energy(net, net.rest, &g, &links, &steric);
  return g.colwise().norm().maxCoeff();
}

}  // namespace rbc
