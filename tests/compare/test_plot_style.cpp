// SPDX-License-Identifier: GPL-3.0-or-later
// The house style of figure text (compare/plot.hpp): real subscripts, the micro sign, no raw
// underscore. render_plot checks every title, axis label, legend entry and label it is given, so
// each test that draws a figure (fig7, tradeoff, stability, dynamics, infer, the accuracy study,
// the Monte Carlo convergence) also checks that figure's text; these tests check the rule.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "compare/plot.hpp"
#include "core/io.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

TEST(PlotStyle, SubscriptsMicroSignsAndEscapedUnderscoresAreAccepted) {
  for (const std::string ok :
       {"diameter (µm)", "D_{A} and D_{T}", "fit t_{c} = 0.12 s", "continuum\\_p2",
        "largest relative error (%)", "sum of 3 umbrellas", "mu (uN/m)", ""})
    EXPECT_NO_THROW(check_plot_text(ok, "test")) << ok;
}

TEST(PlotStyle, RawUnderscoresAndUmAsAUnitAreRefusedNamingTheText) {
  for (const std::string bad : {"D_A", "continuum_p2", "trailing_", "diameter (um)", "um",
                                "error in um vs reference", "the minimiser's reference"}) {
    try {
      check_plot_text(bad, "figure x");
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const std::logic_error& e) {
      EXPECT_NE(std::string(e.what()).find("'" + bad + "'"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("figure x"), std::string::npos) << e.what();
    }
  }
}

TEST(PlotStyle, LiteralTextIsEscapedSoItPassesAndShowsAsWritten) {
  EXPECT_EQ(plot_literal("continuum_p2"), "continuum\\_p2");
  EXPECT_EQ(plot_literal("a^b{c}"), "a\\^b\\{c\\}");
  EXPECT_NO_THROW(check_plot_text(plot_literal("my_data_set"), "test"));
}

TEST(PlotStyle, RenderPlotRefusesAFigureWithARawUnderscoreBeforeWritingAnything) {
  const auto dir = testing::fresh_output_dir("plot_style_refused");
  std::ofstream(dir / "d.csv") << "x,y\n0,1\n1,2\n";
  PlotSpec spec;
  spec.title = "a figure";
  spec.xlabel = "force (pN)";
  spec.ylabel = "diameter (µm)";
  spec.series.push_back({"D_A", "d.csv", "1:2", "lines", "#1f77b4"});
  EXPECT_THROW(render_plot(spec, dir.string(), "refused"), std::logic_error);
  EXPECT_FALSE(std::filesystem::exists(dir / "refused.gp"));
  EXPECT_FALSE(std::filesystem::exists(dir / "refused.png"));
  spec.series.front().title = "D_{A}";
  spec.extra_commands = {"set label 'axial D_A' at graph 0.1, graph 0.9"};
  EXPECT_THROW(render_plot(spec, dir.string(), "refused"), std::logic_error);
  spec.extra_commands = {"set label 'axial D_{A}' at graph 0.1, graph 0.9"};
  render_plot(spec, dir.string(), "accepted");
  EXPECT_TRUE(png_is_complete((dir / "accepted.png").string()));
}

}  // namespace
}  // namespace rbc
