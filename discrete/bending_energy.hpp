#pragma once
// Bending of the lipid bilayer: Canham-Helfrich F_CH = (kappa/2) int (H - H0)^2 dA,
// H = C1 + C2 (MODEL.md section 2; paper eq. (7)), discretised on the network.
#include <string>

#include "core/mesh.hpp"

namespace rbc {

/// kappa in pN*um (2e-19 J = 0.2 pN*um, paper Table 2); H0 in 1/um (pointwise, sum convention).
struct BendingParameters {
  double kappa_pNum = 0.2;
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

/// Juelicher energy of one vertex cell from its sums over the cell's edges and faces:
/// M = sum_lt/2 (um), A = sum_area/3 (um^2), E = (kappa/2)(M - H0 A)^2/A   [pN um].
inline double juelicher_cell_energy(const BendingParameters& p, double sum_lt_um,
                                    double sum_area_um2) {
  const double m = 0.5 * sum_lt_um, a = sum_area_um2 / 3.0;
  const double h = (m - p.h0_per_um * a) / a;  // the cell's H - H0 (1/um)
  return 0.5 * p.kappa_pNum * h * h * a;
}

/// Juelicher energy of one vertex cell, (kappa/2)(M_v - H0 A_v)^2/A_v, from scratch
/// (for local Monte Carlo updates; the sum over v equals juelicher_bending_energy).
double juelicher_vertex_energy(const Positions& x, const Topology& topo,
                               const BendingParameters& params, int v);

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
