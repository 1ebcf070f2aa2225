// SPDX-License-Identifier: GPL-3.0-or-later
#include "compare/plot.hpp"

#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "core/io.hpp"

namespace rbc {

void check_plot_text(const std::string& text, const std::string& where) {
  auto refuse = [&](const std::string& why) {
    throw std::logic_error("plot text '" + text + "' (" + where + "): " + why);
  };
  for (std::size_t i = 0; i < text.size(); ++i)
    if (text[i] == '_' && !(i + 1 < text.size() && text[i + 1] == '{') &&
        !(i > 0 && text[i - 1] == '\\'))
      refuse("a raw underscore; write a subscript as D_{A} or a literal underscore as \\_");
  if (text.find('\'') != std::string::npos)
    refuse("a single quote, which ends gnuplot's quoted string");
  if (find_word(text, "um") != std::string::npos) refuse("'um' as a unit; write µm");
}

std::string plot_literal(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '_' || c == '^' || c == '{' || c == '}' || c == '@' || c == '&' || c == '~')
      out += '\\';
    out += c;
  }
  return out;
}

namespace {
/// The single-quoted strings of a set command that shows text (a label or a title).
std::vector<std::string> shown_strings(const std::string& command) {
  std::vector<std::string> out;
  if (command.rfind("set ", 0) != 0 ||
      (command.find("label") == std::string::npos && command.find("title") == std::string::npos))
    return out;
  for (std::size_t a = command.find('\''); a != std::string::npos;) {
    const std::size_t b = command.find('\'', a + 1);
    if (b == std::string::npos) break;
    out.push_back(command.substr(a + 1, b - a - 1));
    a = command.find('\'', b + 1);
  }
  return out;
}
}  // namespace

void render_plot(const PlotSpec& spec, const std::string& dir, const std::string& name) {
  namespace fs = std::filesystem;
  const std::string png = (fs::path(dir) / (name + ".png")).string();
  check_plot_text(spec.title, name + " title");
  check_plot_text(spec.xlabel, name + " x label");
  check_plot_text(spec.ylabel, name + " y label");
  for (const auto& s : spec.series) check_plot_text(s.title, name + " legend");
  for (const auto& c : spec.extra_commands)
    for (const auto& shown : shown_strings(c)) check_plot_text(shown, name + ": " + c);
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
  if (spec.key.rfind("below", 0) == 0) {
    // A legend below the plot, at most four entries a row: room for its rows under the x
    // label (gnuplot's own margin lets subscripted entries run into the label).
    std::size_t entries = 0;
    for (const auto& s : spec.series) entries += s.title.empty() ? 0 : 1;
    g << "set key maxcols 4\nset bmargin " << 4.0 + 1.6 * double((entries + 3) / 4) << "\n";
  }
  // A log axis can end on a long tick label (1x10^6): room for it inside the canvas.
  if (spec.log_x) g << "set logscale x\nset rmargin 6\n";
  if (spec.log_y) g << "set logscale y\n";
  if (!spec.x_range.empty()) g << "set xrange " << spec.x_range << "\n";
  if (!spec.y_range.empty()) g << "set yrange " << spec.y_range << "\n";
  for (const auto& c : spec.extra_commands) g << c << "\n";
  g << "plot ";
  for (size_t k = 0; k < spec.series.size(); ++k) {
    const auto& s = spec.series[k];
    g << (k ? ", \\\n     " : "") << "'" << s.data_file << "' skip 1 using " << s.columns
      << " with " << s.style << " title '" << s.title << "'";
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
