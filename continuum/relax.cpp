// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/relax.hpp"

#include <chrono>
#include <limits>

namespace rbc {

DiscShape measure_disc(const Positions& x) {
  DiscShape s;
  const double dx = x.row(0).maxCoeff() - x.row(0).minCoeff();
  const double dy = x.row(1).maxCoeff() - x.row(1).minCoeff();
  s.diameter_um = 0.5 * (dx + dy);
  s.thickness_rim_um = x.row(2).maxCoeff() - x.row(2).minCoeff();
  const Eigen::Vector2d centre(0.5 * (x.row(0).maxCoeff() + x.row(0).minCoeff()),
                               0.5 * (x.row(1).maxCoeff() + x.row(1).minCoeff()));
  const double zmid = 0.5 * (x.row(2).maxCoeff() + x.row(2).minCoeff());
  double best_top = std::numeric_limits<double>::infinity(), best_bottom = best_top;
  double z_top = 0, z_bottom = 0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    const double r = (x.col(i).head<2>() - centre).norm();
    if (x(2, i) > zmid && r < best_top) {
      best_top = r;
      z_top = x(2, i);
    } else if (x(2, i) <= zmid && r < best_bottom) {
      best_bottom = r;
      z_bottom = x(2, i);
    }
  }
  s.thickness_centre_um = z_top - z_bottom;
  return s;
}

RelaxResult relax_helfrich(const TriMesh& rest, const BendingParameters& bending,
                           const IsotropicMembraneLaw& regulariser, const NewtonOptions& options,
                           const ProgressSink& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  ContinuumParameters p;
  p.bending = bending;
  const ContinuumModel model = build_continuum_model(rest, regulariser, p);
  RelaxResult r;
  r.x = model.rest;
  r.before = measure_disc(r.x);
  r.energy_before_pNum = juelicher_bending_energy(r.x, model.topo, bending);
  NewtonSolver newton(model, options);
  ConstraintMultipliers lambda;
  r.solve = newton.solve(0.0, r.x, lambda, progress);
  ContinuumEnergyParts parts;
  continuum_energy(model, r.x, 0.0, nullptr, &parts);
  r.energy_after_pNum = parts.bending;
  r.regulariser_energy_pNum =
      parts.inplane - (model.inplane() ? membrane_energy(model, model.rest) : 0.0);
  r.after = measure_disc(r.x);
  r.largest_displacement_um = (r.x - model.rest).colwise().norm().maxCoeff();
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace rbc
