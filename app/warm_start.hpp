// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// `rbc stretch --warm-start DIR`: the equilibria a previous `rbc stretch --out DIR` left
//, read back as the library's StretchState so each force is re-solved from its
// previous equilibrium after a small parameter change instead of by continuation from rest.
#include <string>
#include <vector>

#include "core/mesh.hpp"
#include "discrete/stretch_state.hpp"

namespace rbc::app {

/// Names of the per-shape HDF5 attributes that carry the constraint multipliers, written by
/// `stretch --out` beside force_pN so a later run can warm-start from them.
inline constexpr const char* kLambdaAreaAttribute = "lambda_area_pN_per_um";
inline constexpr const char* kLambdaVolumeAttribute = "lambda_volume_pN_per_um2";

/// Reads DIR/run.json and, for each requested force (pN, in order), the shape it lists in
/// "forces_complete" (positions /mesh/positions_um, faces /mesh/faces, the multiplier
/// attributes). Throws std::invalid_argument ("--warm-start DIR: ...", exit 2) unless the run
/// was made with the same model ("discrete" | "continuum") and mesh orientation ("dimple-vertex"
/// | "mirror-planes"; runs that predate the option used the first), holds every requested
/// force, and every shape lies on the same mesh as `faces` (same vertex count, identical faces:
/// both orientations share their faces, hence the orientation check) with finite values; a
/// missing or corrupt file is named.
StretchState read_warm_start(const std::string& dir, const std::string& model,
                             const std::string& mesh_orientation, Eigen::Index vertices,
                             const Faces& faces, const std::vector<double>& forces_pN);

}  // namespace rbc::app
