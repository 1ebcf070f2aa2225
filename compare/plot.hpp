// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Publication-style PNG plots through gnuplot (pngcairo): the data are written as CSV next
// to the picture, so every plotted number is traceable to a file.
#include <string>
#include <vector>

namespace rbc {

/// One curve or point set. `columns` is gnuplot's `using` spec over the CSV data file. The
/// title is enhanced text in the house style (check_plot_text).
struct PlotSeries {
  std::string title;
  std::string data_file;              ///< CSV with a header line, relative to the plot's directory
  std::string columns;                ///< e.g. "1:2" (lines) or "1:2:3" (yerrorbars)
  std::string style = "linespoints";  ///< gnuplot style: lines, linespoints, yerrorbars, points
  std::string color;                  ///< e.g. "#1f77b4"; empty = gnuplot's default cycle
  int point_type = 7;
  int dash_type = 1;  ///< 1 solid, 2 dashed, ...
};

struct PlotSpec {
  std::string title, xlabel, ylabel;
  bool log_x = false, log_y = false;
  std::string x_range, y_range;                 ///< e.g. "[0:300]"; empty = automatic
  std::string key = "below center horizontal";  ///< inside the plot area or below it
  int width_px = 1100, height_px = 700;
  std::vector<PlotSeries> series;
  std::vector<std::string> extra_commands;  ///< raw gnuplot lines (labels, arrows)
};

/// The house style of every figure's text (titles, axis labels, legend entries, labels): gnuplot
/// enhanced text with real subscripts written D_{A}, a literal underscore written \_, and the
/// micro sign in units (µm, never "um"); no single quote (it ends gnuplot's string). Throws
/// std::logic_error naming the text and `where` otherwise: a caller's mistake, which every test
/// that draws the figure catches.
void check_plot_text(const std::string& text, const std::string& where);

/// Text shown as it is (a file or method name): underscores escaped for enhanced text.
std::string plot_literal(const std::string& text);

/// Writes DIR/NAME.gp and renders DIR/NAME.png (atomically, through run_gnuplot_to_png in
/// core/io.hpp). Throws std::runtime_error if gnuplot is missing or fails, or the PNG does not
/// read back complete, with gnuplot's message.
void render_plot(const PlotSpec& spec, const std::string& dir, const std::string& name);

}  // namespace rbc
