// SPDX-License-Identifier: GPL-3.0-or-later
#include "continuum/surface_grading.hpp"

#include <stdexcept>
#include <string>

#include "core/geometry.hpp"
#include "core/validation.hpp"

namespace rbc {

void SurfaceGradingOptions::validate() const {
  require_integer_in_range("surface grading sweeps", sweeps, 1, 100000);
  require_finite_in_range("surface grading relaxation", "", relaxation, 0.0, 1.0,
                          Ends::open_closed);
}

TriMesh grade_on_evans_fung_surface(const TriMesh& mesh, const EvansFungShape& shape,
                                    const SizeField& size_um,
                                    const SurfaceGradingOptions& options) {
  options.validate();
  const Topology& topo = mesh.topo;
  TriMesh out = mesh;
  for (int i = 0; i < out.x.cols(); ++i) out.x.col(i) = evans_fung_project(shape, out.x.col(i));
  Positions next = out.x;
  for (int sweep = 0; sweep < options.sweeps; ++sweep) {
    for (int i = 0; i < out.x.cols(); ++i) {
      const Vec3 xi = out.x.col(i);
      Vec3 sum = Vec3::Zero();
      double weights = 0;
      for (const int* j = topo.vertex_neighbours.begin(i); j != topo.vertex_neighbours.end(i);
           ++j) {
        const double w = 1.0 / size_um(0.5 * (xi + out.x.col(*j)));
        sum += w * out.x.col(*j);
        weights += w;
      }
      next.col(i) = evans_fung_project(shape, xi + options.relaxation * (sum / weights - xi));
    }
    out.x.swap(next);
  }
  for (int f = 0; f < topo.num_faces(); ++f) {
    const Vec3 a = out.x.col(topo.faces(0, f)), b = out.x.col(topo.faces(1, f)),
               c = out.x.col(topo.faces(2, f));
    const Vec3 centre = (a + b + c) / 3.0;
    if (triangle_normal(a, b, c).dot(evans_fung_level_gradient(shape, centre)) <= 0)
      throw std::runtime_error(
          "surface grading: triangle " + std::to_string(f) +
          " turned over; the size field varies faster than the mesh can follow");
  }
  return out;
}

}  // namespace rbc
