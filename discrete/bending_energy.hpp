// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Bending of the lipid bilayer: Canham-Helfrich F_CH = (kappa/2) int (H - H0)^2 dA,
// H = C1 + C2 (MODEL.md section 2; paper eq. (7)), discretised on the network.
#include <string>

#include <Eigen/Core>
#include <vector>

#include "core/block_pattern.hpp"
#include "core/defaults.hpp"
#include "core/mesh.hpp"
#include "core/units.hpp"

namespace rbc {

/// kappa in pN*um (2e-19 J = 0.2 pN*um, paper Table 2); H0 in 1/um (pointwise, sum convention).
struct BendingParameters {
  double kappa_pNum = units::joule_to_pNum(defaults::kKappa_J);  ///< core/defaults.hpp
  double h0_per_um = 0.0;
  /// Throws std::invalid_argument (rbc::InvalidParameter): kappa in [0, kMaxKappa_J] J (the
  /// message in J), |H0| <= kMaxSpontaneousCurvature_per_um, both finite.
  void validate() const;
};

/// Largest bending rigidity accepted, J (= 1e2 pN um): 500x the RBC's 2e-19 J (paper Table 2),
/// beyond any lipid bilayer (1e-20 to 1e-18 J).
inline constexpr double kMaxKappa_J = 1e-16;
/// Largest |H0| accepted, 1/um: a radius of curvature of 10 nm, a couple of bilayer thicknesses
/// (the cell's own curvatures are ~1/um); larger values have no meaning for a membrane.
inline constexpr double kMaxSpontaneousCurvature_per_um = 100.0;

enum class BendingModel {
  /// Juelicher's edge-based discretisation (default): converges to Canham-Helfrich.
  juelicher,
  /// Kantor-Nelson dihedral energy k_b sum_e (1 - cos(theta_e - theta_0)) (Discher, Li et al.).
  dihedral,
};
std::string to_string(BendingModel m);
BendingModel bending_model_from_string(const std::string& name);

/// How the dihedral stiffness k_b follows from kappa. The dihedral energy converges to
/// (k_b/sqrt3)-weighted integrals that depend on the triangulation; these two mappings:
enum class DihedralMapping {
  /// k_b = 2 sqrt3 kappa: a sphere costs 8 pi kappa on a near-equilateral mesh (default).
  sphere_matched,
  /// k_b = 2 kappa / sqrt3 (Li et al. 2005): the sphere then costs ~8 pi kappa / 3.
  li_et_al,
};
/// k_b in pN*um for the mapping.
double dihedral_stiffness_pNum(double kappa_pNum, DihedralMapping mapping);

/// Juelicher (1996) discretisation, integrated per vertex:
///   M_i = 1/2 sum_{e ni i} L_e theta_e       (um; integrated H = C1 + C2 over the vertex cell)
///   A_i = 1/3 sum_{f ni i} A_f               (um^2, barycentric)
///   E   = (kappa/2) sum_i (M_i - H0 A_i)^2 / A_i                       [pN um]
/// A sphere of any radius gives 8 pi kappa as the mesh is refined (H0 = 0).
/// Gradient (3 x N, pN) if grad != nullptr (accumulated: set it to zero first).
double juelicher_bending_energy(const Positions& x, const Topology& topo,
                                const BendingParameters& params, Positions* grad = nullptr);

struct NetworkGeometry;    // discrete/network_energy.hpp
struct GeometricGradient;  // discrete/network_energy.hpp
/// The same Juelicher energy from the shared geometry (L_e theta_e from geo's lengths and
/// angles, A_f from its areas); adds dE/d(L_e theta_e) = c_e to grad's hinge-angle (c_e L_e)
/// and edge-length (c_e theta_e) coefficients and beta_f to its face-area coefficients (the
/// coefficients of JuelicherHessianTerms) when grad != nullptr.
double juelicher_bending_energy(const Topology& topo, const BendingParameters& params,
                                const NetworkGeometry& geo, GeometricGradient* grad);

/// One Juelicher vertex cell, formed from its sums over the cell's edges and faces; the one
/// place the per-vertex bending quantities are defined (energy, gradient, Hessian and the
/// Monte Carlo local updates all use it).
struct JuelicherCell {
  double m_um = 0;         ///< M = sum_lt/2, integrated H = C1 + C2 over the cell (um)
  double a_um2 = 0;        ///< A = sum_area/3, barycentric cell area (um^2)
  double h_per_um = 0;     ///< h = (M - H0 A)/A, the cell's H - H0 (1/um)
  double energy_pNum = 0;  ///< (kappa/2)(M - H0 A)^2/A = (kappa/2) h^2 A (pN um)
};
inline JuelicherCell juelicher_cell(const BendingParameters& p, double sum_lt_um,
                                    double sum_area_um2) {
  JuelicherCell c;
  c.m_um = 0.5 * sum_lt_um;
  c.a_um2 = sum_area_um2 / 3.0;
  c.h_per_um = (c.m_um - p.h0_per_um * c.a_um2) / c.a_um2;
  c.energy_pNum = 0.5 * p.kappa_pNum * c.h_per_um * c.h_per_um * c.a_um2;
  return c;
}

/// The cell of vertex v from per-edge L_e theta_e (lt(e), um) and per-face areas (af(f),
/// um^2) given by accessors: the one place the sums M_v = 1/2 sum_e L_e theta_e and
/// A_v = 1/3 sum_f A_f are formed, over topo.vertex_edges(v) and topo.vertex_faces(v) in their
/// order. Used by juelicher_cells and by the Monte Carlo sampler (cached or trial values);
/// juelicher_vertex_sums gives the two sums alone (for callers that form the cells in blocks).
template <class EdgeLt, class FaceArea>
void juelicher_vertex_sums(const Topology& topo, int v, EdgeLt&& lt, FaceArea&& af,
                           double& sum_lt_um, double& sum_area_um2) {
  double m = 0, a = 0;
  for (const int* e = topo.vertex_edges.begin(v); e != topo.vertex_edges.end(v); ++e) m += lt(*e);
  for (const int* f = topo.vertex_faces.begin(v); f != topo.vertex_faces.end(v); ++f) a += af(*f);
  sum_lt_um = m;
  sum_area_um2 = a;
}
template <class EdgeLt, class FaceArea>
JuelicherCell juelicher_vertex_cell(const Topology& topo, const BendingParameters& p, int v,
                                    EdgeLt&& lt, FaceArea&& af) {
  double m = 0, a = 0;
  juelicher_vertex_sums(topo, v, lt, af, m, a);
  return juelicher_cell(p, m, a);
}

/// Juelicher's chain-rule coefficients (the formulas of JuelicherHessianTerms below), from the
/// cells' h = H - H0 (1/um): a hinge's dE/d(L_e theta_e) = (kappa/2)(h_a + h_b) [pN], and a
/// face's dE/dA_f at fixed M, -(kappa/3) sum_{k in f} (H0 h_k + h_k^2/2) [pN/um].
inline double juelicher_hinge_coef(const BendingParameters& p, double h_a, double h_b) {
  return 0.5 * p.kappa_pNum * (h_a + h_b);
}
inline double juelicher_face_coef(const BendingParameters& p, const double (&h)[3],
                                  double coef = 0.0) {
  // One division per face (the energy loops are bound by division throughput).
  double s = 0.0;
  for (int k = 0; k < 3; ++k) s += p.h0_per_um * h[k] + 0.5 * h[k] * h[k];
  return coef - p.kappa_pNum * s / 3.0;
}
/// The face coefficient with each corner's cell weighted by w_k (a cell counted w_k times, as a
/// representative of its mirror orbit, or 0 times): -(kappa/3) sum_k w_k (H0 h_k + h_k^2/2).
/// (The hinge coefficient, linear in h, takes the weighted w h directly.)
inline double juelicher_face_coef(const BendingParameters& p, const double (&h)[3],
                                  const double (&w)[3]) {
  double s = 0.0;
  for (int k = 0; k < 3; ++k) s += w[k] * (p.h0_per_um * h[k] + 0.5 * h[k] * h[k]);
  return -p.kappa_pNum * s / 3.0;
}

/// Every vertex cell from per-edge L_e theta_e (lt, um, E entries) and per-face areas (af,
/// um^2, F entries), summed over topo.vertex_edges / vertex_faces in their order.
std::vector<JuelicherCell> juelicher_cells(const Topology& topo, const BendingParameters& params,
                                           const std::vector<double>& lt,
                                           const std::vector<double>& af);

/// The closed star of every vertex (the reach of one Juelicher cell): vertex v, then its
/// neighbours in topo.vertex_neighbours order, with the local slot of every vertex of each
/// incident hinge and face. Built once per mesh.
struct VertexStars {
  std::vector<int> offsets;   ///< star of v: vertices[offsets[v] .. offsets[v + 1])
  std::vector<int> vertices;  ///< v first
  /// Per (v, k-th edge of topo.vertex_edges(v)), at 4 (vertex_edges.offsets[v] + k): the
  /// slots of the hinge's a, b, opposite0, opposite1 in the star.
  std::vector<int> hinge_slots;
  /// Per (v, k-th face of topo.vertex_faces(v)), at 3 (vertex_faces.offsets[v] + k).
  std::vector<int> face_slots;
  int size(int v) const { return offsets[v + 1] - offsets[v]; }
  const int* begin(int v) const { return vertices.data() + offsets[v]; }
};
VertexStars make_vertex_stars(const Topology& topo);

/// The Juelicher Hessian as a sum of element terms (g = (M - H0 A)^2/A has g_MM g_AA =
/// g_MA^2, so each cell's (M, A) form is rank one):
///   d2E = sum_v (kappa/A_v) u_v u_v^T + sum_e c_e d2q_e + sum_f beta_f d2A_f,
///   u_v = dM_v - (H0 + h_v) dA_v (cell_gradient),  c_e = (kappa/2)(h_a + h_b),
///   beta_f = -(kappa/3) sum_{k in f} (H0 h_k + h_k^2/2)                        [pN/um]
/// (q_e = L_e theta_e, d2q_e by element_hessian.hpp, d2A_f its triangle_area_hessian). The
/// Newton preconditioner keeps the semidefinite cell terms and folds beta_f into its face
/// elements; juelicher_hessian adds all three exactly.
struct JuelicherHessianTerms {
  BendingParameters params;
  std::vector<JuelicherCell> cells;             ///< per vertex
  std::vector<Eigen::Matrix<double, 3, 4>> dq;  ///< per edge: d(L theta) (a, b, c, d)
  std::vector<Eigen::Matrix3d> da;              ///< per face: dA_f (columns a, b, c; um)
  double cell_weight(int v) const { return params.kappa_pNum / cells[v].a_um2; }  ///< pN/um^3
  double hinge_coef(const Topology& topo, int e) const;                           ///< c_e (pN)
  /// c + beta_f (pN/um), the face's three terms subtracted from c in vertex order.
  double add_face_coef(const Topology& topo, int f, double c = 0.0) const;
  /// u_v (3 x stars.size(v) entries, star order; um and dimensionless parts as dM, dA/um).
  void cell_gradient(const Topology& topo, const VertexStars& stars, int v, double* u) const;
};
JuelicherHessianTerms juelicher_hessian_terms(const Positions& x, const Topology& topo,
                                              const BendingParameters& params);

/// Adds the exact Juelicher Hessian (pN/um) at x into h; h's pattern must hold every pair
/// within a closed vertex star (continuum/block_hessian.hpp).
void add_juelicher_hessian(const Positions& x, const Topology& topo,
                           const BendingParameters& params, BlockMatrix& h);

/// One Kantor-Nelson hinge, k_b (1 - cos(theta_e - theta0)) [pN um], theta_e the exterior
/// dihedral angle at edge e (0 when flat); its gradient (pN, 3 x 4: a, b, opposite0, opposite1)
/// if grad != nullptr (overwritten). Also the local term Monte Carlo updates.
double dihedral_hinge_energy(const Positions& x, const Topology& topo, double kb_pNum,
                             double theta0_rad, int e, Eigen::Matrix<double, 3, 4>* grad = nullptr);

/// Kantor-Nelson dihedral energy E = k_b sum_e (1 - cos(theta_e - theta0)) [pN um],
/// the sum of dihedral_hinge_energy over all edges. Gradient accumulated into grad.
double dihedral_bending_energy(const Positions& x, const Topology& topo, double kb_pNum,
                               double theta0_rad, Positions* grad = nullptr);

/// One hinge's L_e theta_e (um) with its gradient (3 x 4: a, b, opposite0, opposite1).
double hinge_length_angle(const Positions& x, const Topology& topo, int e,
                          Eigen::Matrix<double, 3, 4>* grad = nullptr);

}  // namespace rbc
