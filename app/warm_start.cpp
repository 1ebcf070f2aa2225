// SPDX-License-Identifier: GPL-3.0-or-later
#include "app/warm_start.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/h5file.hpp"

namespace rbc::app {

namespace {

std::invalid_argument refuse(const std::string& dir, const std::string& why) {
  return std::invalid_argument("--warm-start " + dir + ": " + why);
}

nlohmann::json read_manifest(const std::string& dir) {
  const std::string path = dir + "/run.json";
  if (!std::filesystem::is_regular_file(path))
    throw refuse(dir, "no run.json; expected the --out directory of an earlier `rbc stretch`");
  std::ifstream in(path);
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw refuse(dir, "run.json is not valid JSON (" + std::string(e.what()) + ")");
  }
}

}  // namespace

StretchState read_warm_start(const std::string& dir, const std::string& model,
                             const std::string& mesh_orientation, Eigen::Index vertices,
                             const Faces& faces, const std::vector<double>& forces_pN) {
  const nlohmann::json run = read_manifest(dir);
  if (!run.is_object() || !run.contains("model") || !run["model"].is_string() ||
      !run.contains("forces_complete") || !run["forces_complete"].is_array())
    throw refuse(dir, "run.json lacks \"model\" or \"forces_complete\"; not an rbc stretch run");
  const std::string was = run["model"].get<std::string>();
  if (was != model)
    throw refuse(dir, "the run used --model " + was + ", this one --model " + model +
                          "; expected the same model");
  const std::string orientation =
      run.contains("mesh_orientation") && run["mesh_orientation"].is_string()
          ? run["mesh_orientation"].get<std::string>()
          : "dimple-vertex";
  if (orientation != mesh_orientation)
    throw refuse(dir, "the run used --mesh-orientation " + orientation + ", this one " +
                          mesh_orientation + "; expected the same mesh");
  StretchState state;
  for (const double f : forces_pN) {
    const nlohmann::json* entry = nullptr;
    for (const auto& e : run["forces_complete"])
      if (e.is_object() && e.contains("force_pN") && e["force_pN"].is_number() &&
          e["force_pN"].get<double>() == f && e.contains("shape_h5") && e["shape_h5"].is_string())
        entry = &e;
    if (!entry)
      throw refuse(dir, "holds no completed shape at " + std::to_string(f) +
                            " pN; expected every requested --force to be in its run.json");
    const std::string path = dir + "/" + (*entry)["shape_h5"].get<std::string>();
    std::vector<double> xs;
    std::vector<int> fs;
    double lambda_a = NAN, lambda_v = NAN;
    std::pair<hsize_t, hsize_t> xshape, fshape;
    try {
      const H5File h5 = H5File::open_read(path);
      xshape = h5.read("/mesh/positions_um", xs);
      fshape = h5.read("/mesh/faces", fs);
      lambda_a = h5.read_attribute_double(kLambdaAreaAttribute);
      lambda_v = h5.read_attribute_double(kLambdaVolumeAttribute);
    } catch (const std::runtime_error& e) {
      throw refuse(dir, std::string(e.what()) +
                            "; expected a shape written by `rbc stretch --out` (with the "
                            "multiplier attributes)");
    }
    if (xshape.second != 3 || static_cast<Eigen::Index>(xshape.first) != vertices ||
        fshape.second != 3 || static_cast<Eigen::Index>(fshape.first) != faces.cols())
      throw refuse(dir, path + " holds " + std::to_string(xshape.first) + " vertices and " +
                            std::to_string(fshape.first) + " faces, this mesh " +
                            std::to_string(vertices) + " and " + std::to_string(faces.cols()) +
                            "; expected the same mesh (same --vertices/--elements)");
    const Faces read_faces = Eigen::Map<const Faces>(fs.data(), 3, faces.cols());
    if (read_faces != faces)
      throw refuse(dir, path + " is on a mesh with other faces; expected the same mesh");
    Positions x = Eigen::Map<const Positions>(xs.data(), 3, vertices);
    if (!x.allFinite() || !std::isfinite(lambda_a) || !std::isfinite(lambda_v))
      throw refuse(dir, path + " holds non-finite positions or multipliers");
    state.forces_pN.push_back(f);
    state.x.push_back(std::move(x));
    state.multipliers.push_back({lambda_a, lambda_v});
  }
  return state;
}

}  // namespace rbc::app
