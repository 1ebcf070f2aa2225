// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <functional>
#include <string>
#include <vector>
// The spectrin network of Model 1 on a closed triangulation, with its stress-free
// per-element reference (MODEL.md section 2), and its total free energy.
#include <string>

#include "core/mesh.hpp"
#include "discrete/bending_energy.hpp"
#include "discrete/constraint_energy.hpp"
#include "discrete/steric_energy.hpp"
#include "discrete/tweezers.hpp"
#include "discrete/wlc.hpp"

namespace rbc {

/// Every parameter of Model 1, internal units, documented defaults (paper Tables 1-2).
struct NetworkParameters {
  WlcParameters wlc;
  WlcExpansion expansion = WlcExpansion::full;
  StericParameters steric;
  BendingParameters bending;
  BendingModel bending_model = BendingModel::juelicher;
  DihedralMapping dihedral_mapping = DihedralMapping::sphere_matched;
  ConstraintParameters constraints;
  TweezersParameters tweezers;
  void validate() const;
};

/// A network ready to evaluate: topology, rest positions X, per-edge Lbar_e and per-face
/// Abar_f taken from X (so every element is stress-free at its own reference), the
/// material constants derived once, and the bead patches.
struct Network;
struct LoadState;
struct EnergyBreakdown;
struct NetworkGeometry;    // discrete/network_energy.hpp
struct GeometricGradient;  // discrete/network_energy.hpp

/// What a term is to the solvers that need more than its value and gradient: the Newton
/// preconditioner (discrete/network_hessian.hpp) and the Monte Carlo sampler
/// (discrete/mc_sampler.hpp) walk the model's list and assemble each production term with its
/// own kernels (the in-plane, bending and area/volume Hessians share face elements that are
/// projected together; the sampler caches per-edge and per-face values they share); a custom
/// term brings its Hessian blocks and local energies through LocalPieces.
enum class TermKind {
  custom,
  in_plane,
  juelicher_bending,
  dihedral_bending,
  area_volume,
  tweezers
};

/// Vertex lists of a term's pieces: piece p reads vertices[offsets[p] .. offsets[p+1]).
struct PieceLayout {
  std::vector<int> offsets{0};
  std::vector<int> vertices;
  int count() const { return static_cast<int>(offsets.size()) - 1; }
};

/// A custom term written as a sum of local pieces, E = sum_p e_p(x), each reading only its own
/// vertices, listed pairwise within graph distance 2 (so that same-colour Monte Carlo moves,
/// at distance >= 3, never change one piece together). The hooks the Newton preconditioner
/// (hessian) and the Monte Carlo sampler (energy) call; an unset hook means the term offers
/// no such part (the preconditioner then leaves the term out, the sampler refuses the model).
struct LocalPieces {
  std::function<PieceLayout(const Network& net)> layout;  ///< fixed per topology
  /// e_p at x (pN um; +infinity outside the domain); the pieces sum to the term's energy.
  std::function<double(const Network& net, const Positions& x, int piece)> energy;
  /// d2 e_p / dx dx (3k x 3k, k the piece's vertices in layout order; pN/um).
  std::function<Eigen::MatrixXd(const Network& net, const Positions& x, int piece)> hessian;
};

/// One energy term of a network model (the interface every term of the sum implements):
/// returns its energy at x under `load` (pN um; +infinity outside its domain, grad then
/// unspecified), adds its gradient (pN) into *grad when non-null, and adds its value into its
/// field(s) of `parts`. A model is the list of its terms; network_energy sums the list, and
/// the Newton preconditioner and the Monte Carlo sampler assemble their parts from it (kind,
/// pieces).
struct NetworkTerm {
  std::string name;  ///< e.g. "in-plane", "bending (juelicher)"
  std::function<double(const Network& net, const Positions& x, const LoadState& load,
                       Positions* grad, EnergyBreakdown& parts)>
      energy;
  /// Optional: the same energy from the geometry of x shared by the terms
  /// (discrete/network_energy.hpp), adding its derivatives with respect to the geometric
  /// primitives into *grad when non-null. When every term of a list has it,
  /// sum_network_terms computes the geometry once and assembles the gradient once (the
  /// production terms all have it). It must agree with `energy` up to round-off.
  std::function<double(const Network& net, const Positions& x, const NetworkGeometry& geo,
                       const LoadState& load, GeometricGradient* grad, EnergyBreakdown& parts)>
      from_geometry = {};
  TermKind kind = TermKind::custom;
  LocalPieces pieces;  ///< custom terms: Hessian blocks and local energies
};

struct Network {
  Topology topo;
  Positions rest;            ///< 3 x N, um
  Eigen::VectorXd lbar_um;   ///< E, rest link lengths
  Eigen::VectorXd abar_um2;  ///< F, rest face areas
  WlcDensity wlc;
  StericParameters steric;
  double steric_C_pN_per_um = 0;
  BendingParameters bending;
  BendingModel bending_model = BendingModel::juelicher;
  double dihedral_kb_pNum = 0;
  ConstraintParameters constraints;
  double area0_um2 = 0, volume0_um3 = 0;
  TweezerPatch patch;
  /// The model's terms; empty (the default) = network_terms(*this), the production list. A
  /// model with its own list (e.g. another bending law: one NetworkTerm) is set here; the
  /// stretch drivers then minimise that sum, the Newton preconditioner assembles its Hessian
  /// and the Monte Carlo sampler its local energies from it (model_terms).
  std::vector<NetworkTerm> terms;
};

Network build_network(const TriMesh& rest_mesh, const NetworkParameters& params);

/// The external state an energy evaluation needs besides positions.
struct LoadState {
  double force_pN = 0.0;  ///< total bead force F pulling each end along +-x
  ConstraintMultipliers multipliers;
  /// Multiplies the network's area and volume penalty stiffnesses (the augmented-Lagrangian
  /// loop raises it when a multiplier update alone stops reducing the violation).
  double stiffness_scale = 1.0;
};

/// Energy of each term (pN um).
struct EnergyBreakdown {
  double links = 0, steric = 0, bending = 0, constraints = 0, tweezers = 0;
  double total() const { return links + steric + bending + constraints + tweezers; }
};

/// Smallest face area ratio A/Abar below which a configuration counts as infeasible
/// (a collapsed or inverted face).
inline constexpr double kCollapsedFaceRatio = 1e-3;

/// Total free energy F = links + steric + bending + constraints - tweezer work (pN um).
/// Returns +infinity for infeasible x (a link at/after Lmax, a collapsed face); then grad
/// is unspecified. grad (3 x N, pN) is overwritten when given.
/// The production terms of `net`, in the order they are summed: "in-plane" (WLC links and
/// steric faces, parts.links and parts.steric), the bending law of net.bending_model
/// (parts.bending), "area/volume" (parts.constraints, penalties times load.stiffness_scale),
/// "tweezers" (parts.tweezers).
std::vector<NetworkTerm> network_terms(const Network& net);

/// The list a network's model is: net.terms, or the production list when that is empty.
const std::vector<NetworkTerm>& model_terms(const Network& net);
/// Whether the model's list holds a term of this kind.
bool has_term(const Network& net, TermKind kind);

/// The terms' sum at x: grad (when given) is zeroed, then each term adds its gradient; returns
/// +infinity as soon as a term is not finite-below-infinity. parts receives the breakdown.
/// When every term has from_geometry, that path is taken (one geometry pass, one assembly).
double sum_network_terms(const std::vector<NetworkTerm>& terms, const Network& net,
                         const Positions& x, const LoadState& load, Positions* grad,
                         EnergyBreakdown* parts);

double network_energy(const Network& net, const Positions& x, const LoadState& load,
                      Positions* grad = nullptr, EnergyBreakdown* parts = nullptr);

/// In-plane (links + steric) force magnitudes at the rest shape: the largest over vertices
/// (pN). MODEL.md: equals (f_WLC(Lbar)/Lbar) |grad Phi| and should be small and normal.
double largest_rest_inplane_force_pN(const Network& net);

}  // namespace rbc
