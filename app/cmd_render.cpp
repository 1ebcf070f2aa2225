// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc render`: a picture of any shape rbc wrote (app/render.hpp).
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>

#include "app/cli_util.hpp"
#include "app/commands.hpp"
#include "app/render.hpp"
#include "app/run_config.hpp"

namespace rbc::app {

void add_render_command(CLI::App& app, Action& action) {
  auto o = std::make_shared<RenderRequest>();
  auto* cmd = app.add_subcommand(
      "render",
      "Draw shapes rbc wrote (.xdmf or .h5: stretch, mc, dynamics, mesh, relax) to a PNG: one "
      "row per shape (a dynamics series gives its first and last frames), an oblique view and "
      "the view from above, coloured by one field on one scale");
  add_config_option(cmd);
  cmd->add_option("files", o->files, "shape files (.xdmf or .h5)")->required();
  cmd->add_option("--out", o->out_png, "the PNG to write")->required();
  cmd->add_option("--field", o->field,
                  "colour by this field (default: tension_max_pN_per_um, displacement_um, "
                  "displacement_x_um or height_um, the first every file has)");
  cmd->add_option("--title", o->title, "a title above the picture (default: none)");
  cmd->callback([o, cmd, &action] {
    action = [o, cmd] {
      namespace fs = std::filesystem;
      for (const auto& file : o->files) {
        std::error_code ec;
        if (!fs::is_regular_file(file, ec))
          throw std::invalid_argument(file + ": expected an existing .xdmf or .h5 shape file");
        const auto ext = fs::path(file).extension();
        if (ext != ".xdmf" && ext != ".h5")
          throw std::invalid_argument(file + ": expected a .xdmf or .h5 shape file");
      }
      if (fs::path(o->out_png).extension() != ".png")
        throw std::invalid_argument("--out " + o->out_png + ": expected a file name ending .png");
      check_output_file(o->out_png, "--out");
      if (const std::string why = renderer_unavailable_reason(); !why.empty())
        throw std::invalid_argument("render: " + why);
      o->metadata = record_png_text(run_record(*cmd));
      render_shapes(*o);
      std::cout << o->out_png << "\n";
      return 0;
    };
  });
}

}  // namespace rbc::app
