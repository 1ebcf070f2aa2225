// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Pictures of cells for the command line: runs python/rbc/render.py (embedded in the executable
// at build time, so an installed `rbc` needs no file beside it) with the Debian python3, whose
// numpy, h5py, meshio and matplotlib draw the shapes. The same file is `rbc.plot_shape` in the
// Python package, so both front ends draw the same picture.
#include <string>
#include <utility>
#include <vector>

namespace rbc::app {

/// What to draw: shape files (.xdmf or .h5 written by rbc), one row each, two views.
struct RenderRequest {
  std::vector<std::string> files;
  std::string out_png;  ///< written atomically (a temporary in the same directory, then renamed)
  std::string field;    ///< colour field; empty = the first of the preferred fields all files have
  std::string title;    ///< figure title; empty = none
  /// PNG text chunks (key, text): what produced the picture (run_config.hpp, record_png_text).
  std::vector<std::pair<std::string, std::string>> metadata = {};
};

/// The interpreter the pictures use: $RBC_PYTHON if set, else /usr/bin/python3 if present, else
/// python3 on PATH.
std::string render_python();

/// Empty if render_python() imports numpy, h5py, meshio and matplotlib; otherwise one sentence
/// saying what is missing and the Debian packages that provide it.
std::string renderer_unavailable_reason();

/// Draws the request's shapes into out_png; throws std::runtime_error naming the PNG and the
/// renderer's message if it fails (a file without triangles, an unknown field).
void render_shapes(const RenderRequest& request);

/// The picture a command writes beside its shapes (`OUT/cells.png`): draws `request` unless the
/// renderer is unavailable or fails, in which case nothing is written and the reason is
/// returned (a picture never fails the run that computed the shapes); "" when drawn.
std::string draw_cells(const RenderRequest& request);

}  // namespace rbc::app
