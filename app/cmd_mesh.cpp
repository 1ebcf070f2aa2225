// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc mesh`: generate the Evans-Fung rest triangulation and report its quality.
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/run_config.hpp"
#include "core/geometry.hpp"
#include "core/io.hpp"
#include "core/rest_shape.hpp"

namespace rbc::app {

nlohmann::json mesh_report_json(const MeshQualityReport& r) {
  return {{"vertices", r.vertices},
          {"edges", r.edges},
          {"faces", r.faces},
          {"area_um2", r.area_um2},
          {"volume_um3", r.volume_um3},
          {"diameter_um", r.diameter_um},
          {"thickness_um", r.thickness_um},
          {"phi_over_area", r.phi_over_area},
          {"edge_min_um", r.edge_min_um},
          {"edge_mean_um", r.edge_mean_um},
          {"edge_max_um", r.edge_max_um},
          {"worst_aspect_ratio", r.worst_aspect_ratio},
          {"degree_histogram", r.degree_histogram},
          {"phi_iterations", r.phi_iterations},
          {"volume_scale", r.volume_scale}};
}

void add_mesh_command(CLI::App& app, Action& action) {
  struct Opts {
    int vertices = 2000;
    std::string quality = "phi-minimised";
    std::string orientation = "dimple-vertex";
    std::string out;
    bool json = false, overwrite = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd =
      app.add_subcommand("mesh", "Triangulate the Evans-Fung rest shape and report its quality");
  add_config_option(cmd);
  cmd->add_option("--vertices,-n", o->vertices, "vertex count N (100 to 40,000; hit within 10 %)")
      ->check(integer_in(100, 40000))
      ->capture_default_str();
  cmd->add_option("--quality", o->quality, "phi-minimised | projected | equal-area")
      ->check(CLI::IsMember({"phi-minimised", "projected", "equal-area"}))
      ->capture_default_str();
  cmd->add_option("--orientation", o->orientation,
                  "dimple-vertex | mirror-planes (the icosahedron's two-fold axes along x, y, z: "
                  "the mesh keeps all three coordinate mirrors; as rbc stretch "
                  "--mesh-orientation)")
      ->check(CLI::IsMember({"dimple-vertex", "mirror-planes"}))
      ->capture_default_str();
  cmd->add_option("--out", o->out,
                  "write DIR/rest_shape.h5/.xdmf and DIR/mesh_quality.json (must be empty "
                  "unless --force-overwrite)")
      ->check(nonempty_path());
  cmd->add_flag("--force-overwrite", o->overwrite, "allow a non-empty --out");
  cmd->add_flag("--json", o->json, "print the report as JSON");
  cmd->callback([o, cmd, &action] {
    action = [o, cmd] {
      const nlohmann::json record = run_record(*cmd);
      RestShapeOptions ro;
      ro.target_vertices = o->vertices;
      ro.quality = rest_mesh_quality_from_string(o->quality);
      ro.orientation = triangulation_orientation_from_string(o->orientation);
      if (!o->out.empty()) prepare_output_directory(o->out, o->overwrite);
      MeshQualityReport r;
      const TriMesh m = make_rest_shape(ro, &r);
      const nlohmann::json j = mesh_report_json(r);
      if (!o->out.empty()) {
        MeshSnapshot s{m.x, m.topo.faces, {{"vertex_area_um2", vertex_areas(m.x, m.topo)}},
                       {},  {},           record_attributes(record)};
        write_mesh_snapshot(o->out + "/rest_shape", s);
        write_text_atomic(o->out + "/mesh_quality.json", j.dump(2) + "\n");
        write_run_record(o->out, record);
      }
      if (o->json) {
        nlohmann::json out = record;
        out.update(j);
        std::cout << out.dump(2) << "\n";
      } else {
        std::cout << std::setprecision(5) << "vertices " << r.vertices << ", edges " << r.edges
                  << ", faces " << r.faces << "\narea " << r.area_um2 << " um^2, volume "
                  << r.volume_um3 << " um^3, diameter " << r.diameter_um << " um, thickness "
                  << r.thickness_um << " um\nPhi/A0 " << r.phi_over_area << ", edges min/mean/max "
                  << r.edge_min_um << "/" << r.edge_mean_um << "/" << r.edge_max_um
                  << " um, worst aspect ratio " << r.worst_aspect_ratio << "\ndegree histogram:";
        for (size_t d = 0; d < r.degree_histogram.size(); ++d)
          if (r.degree_histogram[d]) std::cout << " " << d << ":" << r.degree_histogram[d];
        std::cout << "\n";
      }
      return 0;
    };
  });
}

}  // namespace rbc::app
