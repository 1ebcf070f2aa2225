// SPDX-License-Identifier: GPL-3.0-or-later
// Uses an installed rbc (find_package(rbc), target rbc::continuum): the area of a continuum mesh
// of the Evans-Fung rest shape and one optical-tweezers stretch of it, with the defaults of
// `rbc stretch --model continuum --elements 500 --force 0,88` (the order-2 law of the default
// spectrin network). Prints one "name value" pair per line; .ci/install_check.sh checks them.
#include <cstdio>
#include <vector>

#include "continuum/continuum_model.hpp"
#include "continuum/continuum_stretch.hpp"
#include "core/geometry.hpp"
#include "core/rest_shape.hpp"
#include "core/version.hpp"
#include "homogenise/invariant_laws.hpp"

int main() {
  constexpr int kElements = 500;
  const rbc::TriMesh mesh = rbc::make_continuum_mesh(kElements);
  const rbc::ContinuumModel model = rbc::build_continuum_model(
      mesh,
      rbc::make_membrane_law(rbc::WlcParameters{}, rbc::StericParameters{},
                             rbc::WlcExpansion::order2),
      rbc::ContinuumParameters{});
  rbc::ContinuumOptions options;
  options.newton.max_iterations = 1000;  // as the CLI's continuum stretch
  options.element_fields = false;
  const std::vector<double> forces_pN = {0.0, 88.0};
  const std::vector<rbc::ContinuumStretchPoint> points =
      rbc::run_continuum_stretch(model, forces_pN, options);

  std::printf("version %s\n", rbc::version_string().c_str());
  std::printf("elements %d\n", model.num_elements());
  std::printf("area_um2 %.10g\n", rbc::total_area(mesh.x, mesh.topo));
  std::printf("evans_fung_area_um2 %.10g\n", rbc::kEvansFungArea_um2);
  bool converged = true;
  for (const rbc::ContinuumStretchPoint& p : points) {
    std::printf("force_pN %.10g axial_um %.17g transverse_um %.17g\n", p.force_pN, p.axial_um,
                p.transverse_um);
    converged = converged && p.converged;
  }
  return converged ? 0 : 1;
}
