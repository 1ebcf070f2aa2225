// SPDX-License-Identifier: GPL-3.0-or-later
#include "compare/plot.hpp"

#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "core/io.hpp"

namespace rbc {

void render_plot(const PlotSpec& spec, const std::string& dir, const std::string& name) {
  namespace fs = std::filesystem;
  const std::string png = (fs::path(dir) / (name + ".png")).string();
  std::ostringstream g;
  g << "set terminal pngcairo size " << spec.width_px << "," << spec.height_px
    << " enhanced font 'DejaVu Sans,12'\n"
    // The script names the final PNG (run by hand it writes NAME.png); rbc passes the
    // temporary's name in `rbc_output` and renames it once the PNG reads back complete.
    << "if (!exists('rbc_output')) rbc_output = '" << name << ".png'\n"
    << "set output rbc_output\n"
    << "set datafile separator ','\nset datafile commentschars '#'\n"
    << "set title '" << spec.title << "'\nset xlabel '" << spec.xlabel << "'\nset ylabel '"
    << spec.ylabel << "'\nset key " << spec.key << "\nset grid\n";
  if (spec.log_x) g << "set logscale x\n";
  if (spec.log_y) g << "set logscale y\n";
  if (!spec.x_range.empty()) g << "set xrange " << spec.x_range << "\n";
  if (!spec.y_range.empty()) g << "set yrange " << spec.y_range << "\n";
  for (const auto& c : spec.extra_commands) g << c << "\n";
  g << "plot ";
  for (size_t k = 0; k < spec.series.size(); ++k) {
    const auto& s = spec.series[k];
    g << (k ? ", \\\n     " : "") << "'" << s.data_file << "' skip 1 using " << s.columns
      << " with " << s.style << " title '" << s.title << "' noenhanced";
    if (!s.color.empty()) g << " lc rgb '" << s.color << "'";
    if (s.style.find("points") != std::string::npos || s.style == "yerrorbars")
      g << " pt " << s.point_type;
    if (s.style.find("lines") != std::string::npos) g << " lw 2 dt " << s.dash_type;
  }
  g << "\nset output\n";
  const std::string script = (fs::path(dir) / (name + ".gp")).string();
  write_text_atomic(script, g.str());
  // gnuplot writes the temporary in `dir`; the PNG counts only when it reads back complete.
  run_gnuplot_to_png(dir, name + ".gp", png);
}

}  // namespace rbc
