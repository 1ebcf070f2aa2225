// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The continuum membrane of MODEL.md section 4 (paper's Model 2, static): a surface finite
// element mesh of the Evans-Fung rest shape, chosen freely and independent of any spectrin
// network, carrying
//   E[x] = sum_T Abar_T Psi(I1, I2)        in-plane law (homogenise/membrane_law.hpp contract)
//        + F_CH[x]                          Canham-Helfrich, Juelicher discretisation
//        - F sum_i share_i e_x.(x_i - X_i)  optical tweezers (discrete/tweezers.hpp)
// with the total area and enclosed volume held exactly by Lagrange multipliers (solver).
// The rest mesh is the stress-free reference: Psi is stationary at F = I on any mesh.
#include <Eigen/Core>
#include <vector>

#include "continuum/block_hessian.hpp"
#include "continuum/membrane_element.hpp"
#include "core/mesh.hpp"
#include "core/rest_shape.hpp"
#include "discrete/bending_energy.hpp"
#include "discrete/tweezers.hpp"
#include "homogenise/membrane_law.hpp"

namespace rbc {

/// Element counts make_continuum_mesh accepts (F = 2N - 4 with N in make_rest_shape's range).
inline constexpr int kMinContinuumElements = 200;
inline constexpr int kMaxContinuumElements = 79996;

/// Phi-minimised closed triangulation of the Evans-Fung surface with about `elements`
/// triangles (N = elements/2 + 2 vertices; icosphere counts are quantised, within 10 %).
/// Throws std::invalid_argument if elements is outside [kMinContinuumElements,
/// kMaxContinuumElements].
TriMesh make_continuum_mesh(int elements, const EvansFungShape& shape = {},
                            MeshQualityReport* report = nullptr);
/// The same mesh laid in `orientation` (core/rest_shape.hpp TriangulationOrientation) and
/// turned by RestShapeOptions::rotation_seed before the Phi minimisation (0 and dimple_vertex:
/// identical to the overload above).
TriMesh make_continuum_mesh(
    int elements, unsigned rotation_seed,
    TriangulationOrientation orientation = TriangulationOrientation::dimple_vertex,
    MeshQualityReport* report = nullptr);

/// Physics of the continuum model other than the in-plane law. Defaults: kappa = 0.2 pN um
/// (2e-19 J, paper Table 2), H0 = 0, contact patches of 5 % area per bead.
struct ContinuumParameters {
  BendingParameters bending;
  TweezersParameters tweezers;
  void validate() const;  ///< delegates to the members
};

/// The law factor x Psi (all derivatives scaled): e.g. a weak regulariser.
IsotropicMembraneLaw scaled_law(const IsotropicMembraneLaw& law, double factor);

/// A continuum model ready to evaluate (prepared, immutable state).
struct ContinuumModel {
  Topology topo;
  Positions rest;                            ///< 3 x N reference positions X (um)
  std::vector<MembraneReference> reference;  ///< per element (size F)
  IsotropicMembraneLaw law;                  ///< evaluate empty: in-plane elasticity off
  BendingParameters bending;
  TweezerPatch patch;
  double area0_um2 = 0, volume0_um3 = 0;  ///< the constrained values (those of the rest mesh)
  bool inplane() const { return static_cast<bool>(law.evaluate); }
  int num_elements() const { return topo.num_faces(); }
};

/// Builds the model on a rest mesh. law.evaluate may be empty (Helfrich-only relaxation).
ContinuumModel build_continuum_model(const TriMesh& rest, const IsotropicMembraneLaw& law,
                                     const ContinuumParameters& params);

/// Energy of each term (pN um).
struct ContinuumEnergyParts {
  double inplane = 0, bending = 0, tweezers = 0;
  double total() const { return inplane + bending + tweezers; }
};

/// In-plane energy sum_T Abar_T Psi (pN um), gradient (3 x N, pN) accumulated into grad.
/// +infinity if an element collapses (J < kCollapsedElementRatio) or the law is infinite.
double membrane_energy(const ContinuumModel& model, const Positions& x, Positions* grad = nullptr);
/// Adds the in-plane Hessian (pN/um) into h.
void add_membrane_hessian(const ContinuumModel& model, const Positions& x, BlockHessian& h);

/// E(x) at bead force F (pN): in-plane + bending - tweezers work (pN um). Returns
/// +infinity for an infeasible x (an element collapsed to less than kCollapsedElementRatio
/// of its reference area, in-plane law infinite). grad (3 x N, pN) is overwritten.
double continuum_energy(const ContinuumModel& model, const Positions& x, double force_pN,
                        Positions* grad = nullptr, ContinuumEnergyParts* parts = nullptr);

/// Adds d2E (in-plane + bending; the tweezers work is linear) into h (pN/um).
void add_continuum_hessian(const ContinuumModel& model, const Positions& x, BlockHessian& h);

/// Total area A (um^2) and enclosed volume V (um^3) with their gradients (3 x N).
struct ConstraintValues {
  double area_um2 = 0, volume_um3 = 0;
  Positions grad_area, grad_volume;
};
ConstraintValues evaluate_constraints(const Positions& x, const Topology& topo);
/// Adds area_coef d2A + volume_coef d2V into h.
void add_constraint_hessian(const Positions& x, const Topology& topo, double area_coef,
                            double volume_coef, BlockHessian& h);

/// Adds the Hessian of the Lagrangian, d2E + area_coef d2A + volume_coef d2V (pN/um; the
/// coefficients are the multipliers lambda_A in pN/um and lambda_V in pN/um^2), into h in one
/// pass: each face's membrane element, Juelicher face term and constraint terms share one
/// triangle area Hessian, and every block is added through h's cached codes. Equal to
/// add_continuum_hessian + add_constraint_hessian up to rounding.
void add_lagrangian_hessian(const ContinuumModel& model, const Positions& x, double area_coef,
                            double volume_coef, BlockHessian& h);

/// The element matrices add_lagrangian_hessian sums (pN/um), one element at a time, for
/// assemblies over a subset of elements (continuum/reduced_hessian.hpp): face f's 9 x 9
/// (membrane element + (Psi_1 + area_coef + Juelicher beta_f) d2A + volume_coef d2V; vertex
/// order of topo.faces) and hinge e's 12 x 12 (c_e d2(L theta); a, b, opposite0, opposite1).
/// `terms` is juelicher_hessian_terms at x.
void lagrangian_face_hessian(const ContinuumModel& model, const Positions& x,
                             const JuelicherHessianTerms& terms, int f, double area_coef,
                             double volume_coef, Matrix9d& hf);
void lagrangian_hinge_hessian(const ContinuumModel& model, const Positions& x,
                              const JuelicherHessianTerms& terms, int e, Matrix12d& he);

/// Per-element output fields: invariants and principal surface tensions (pN/um).
struct ElementFields {
  Eigen::VectorXd i1, i2, tension_max_pN_per_um, tension_min_pN_per_um;
};
ElementFields element_fields(const ContinuumModel& model, const Positions& x);

}  // namespace rbc
