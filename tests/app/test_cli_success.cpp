// SPDX-License-Identifier: GPL-3.0-or-later
// Success paths of the study commands (`rbc fig7`, `rbc tradeoff`, `rbc stability`, `rbc
// report`): exit 0, every documented output present and parseable, and numbers that equal what
// another command or a formula computes independently: a method's diameters equal `rbc stretch
// --json` at the same force and size, the fit equals the RMS recomputed from the Mills data, the
// trade-off reference equals the Richardson formula applied to its rows, the steric area modulus
// equals `rbc moduli`'s paper formula, and the report's tables equal the files beside it.
//
// Every run pins OMP_NUM_THREADS=1 (the stretch solves it is compared with then take the same
// path bit for bit), reads JSON from stdout alone (stderr goes to a file) and writes only under
// build/test_output/cli_success_<name>.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace {
namespace fs = std::filesystem;
using nlohmann::json;

struct CommandRun {
  int exit_code;
  std::string out;  ///< stdout only
  std::string err;  ///< stderr (read back from its file)
};

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// A fresh, empty directory build/test_output/cli_success_<name>.
std::string fresh_dir(const std::string& name) {
  const std::string dir = std::string(RBC_BINARY_DIR) + "/test_output/cli_success_" + name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

/// Runs build/rbc ARGS on one OpenMP thread; stdout is captured, stderr goes to
/// DIR/stderr_<tag>.txt and is read back.
CommandRun rbc(const std::string& args, const std::string& dir, const std::string& tag) {
  const std::string err_file = dir + "/stderr_" + tag + ".txt";
  const std::string cmd = "env OMP_NUM_THREADS=1 " + std::string(RBC_BINARY_DIR) + "/rbc " + args +
                          " 2> '" + err_file + "'";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return {-1, "", "popen failed"};
  std::string out;
  std::array<char, 4096> buf{};
  size_t n = 0;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) out.append(buf.data(), n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out, read_text(err_file)};
}

/// `rbc stretch ARGS --json -q`: the points of the run printed on stdout.
json stretch_points(const std::string& args, const std::string& dir, const std::string& tag) {
  const CommandRun r = rbc("stretch " + args + " --json -q", dir, tag);
  EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.err;
  if (r.exit_code != 0) return json::array();
  return json::parse(r.out).at("points");  // --json: {command, config, provenance, points}
}

json read_json(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  return json::parse(in);
}

/// A numeric CSV file: '#' comment lines, one header line, rows of numbers.
struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  size_t col(const std::string& name) const {
    const auto it = std::find(header.begin(), header.end(), name);
    EXPECT_NE(it, header.end()) << name;
    return static_cast<size_t>(it - header.begin());
  }
};

std::vector<std::string> split(const std::string& line, char sep) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  for (std::string c; std::getline(ss, c, sep);) cells.push_back(c);
  return cells;
}

/// A numeric CSV; with `labelled`, its first column (the rows' names) is left out.
Csv read_numeric_csv(const std::string& path, bool labelled = false) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  Csv t;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    if (labelled) line = line.substr(line.find(',') + 1);
    if (t.header.empty()) {
      t.header = split(line, ',');
      continue;
    }
    std::vector<double> row;
    for (const auto& c : split(line, ',')) row.push_back(std::stod(c));
    EXPECT_EQ(row.size(), t.header.size()) << path << ": " << line;
    t.rows.push_back(std::move(row));
  }
  return t;
}

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(' ');
  const size_t b = s.find_last_not_of(' ');
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

/// The cells of the Markdown table rows of `md` whose first cell is `first` (trimmed).
std::vector<std::vector<std::string>> table_rows(const std::string& md, const std::string& first) {
  std::vector<std::vector<std::string>> out;
  std::stringstream ss(md);
  for (std::string line; std::getline(ss, line);) {
    if (line.size() < 2 || line[0] != '|') continue;
    std::vector<std::string> cells;
    for (const auto& c : split(line.substr(1), '|')) cells.push_back(trim(c));
    if (!cells.empty() && cells[0] == first) out.push_back(cells);
  }
  return out;
}

/// The part of `md` from the line `heading` to the next heading of the same or a higher level
/// (empty if the heading is missing).
std::string section(const std::string& md, const std::string& heading) {
  const size_t at = md.find(heading + "\n");
  EXPECT_NE(at, std::string::npos) << heading;
  if (at == std::string::npos) return "";
  const std::string level = heading.substr(0, heading.find(' ') + 1);  // "## "
  size_t end = at + heading.size();
  while ((end = md.find("\n#", end)) != std::string::npos) {
    const size_t hashes = md.find_first_not_of('#', end + 1) - (end + 1);
    if (hashes <= level.size() - 1) break;
    ++end;
  }
  return md.substr(at, end == std::string::npos ? std::string::npos : end - at);
}

/// The number that follows the first occurrence of `key` at or after `from` in `text`.
double number_after(const std::string& text, const std::string& key, size_t from = 0) {
  const size_t at = text.find(key, from);
  EXPECT_NE(at, std::string::npos) << key;
  if (at == std::string::npos) return std::nan("");
  return std::stod(text.substr(at + key.size()));
}

/// Mills-style fit of a model curve (forces increasing, covering the data): RMS of D_A and D_T
/// over the data points, the model interpolated linearly in force, and the points within their
/// error bars (the definition fig7.json documents: rms in um; inside = within the error bar).
struct Fit {
  double axial_rms = 0, transverse_rms = 0;
  int axial_inside = 0, transverse_inside = 0;
};
Fit fit_to_data(const Csv& data, const json& curve) {
  const size_t f = data.col("force_pN"), a = data.col("axial_um"), ae = data.col("axial_err_um"),
               t = data.col("transverse_um"), te = data.col("transverse_err_um");
  Fit q;
  for (const auto& row : data.rows) {
    double ma = std::nan(""), mt = std::nan("");
    for (size_t k = 0; k < curve.size(); ++k) {
      const double fk = curve[k]["force_pN"].get<double>();
      if (fk < row[f]) continue;
      if (fk == row[f] || k == 0) {
        ma = curve[k]["axial_um"].get<double>();
        mt = curve[k]["transverse_um"].get<double>();
      } else {
        const double f0 = curve[k - 1]["force_pN"].get<double>();
        const double w = (row[f] - f0) / (fk - f0);
        ma = (1 - w) * curve[k - 1]["axial_um"].get<double>() +
             w * curve[k]["axial_um"].get<double>();
        mt = (1 - w) * curve[k - 1]["transverse_um"].get<double>() +
             w * curve[k]["transverse_um"].get<double>();
      }
      break;
    }
    q.axial_rms += (ma - row[a]) * (ma - row[a]);
    q.transverse_rms += (mt - row[t]) * (mt - row[t]);
    q.axial_inside += std::abs(ma - row[a]) <= row[ae];
    q.transverse_inside += std::abs(mt - row[t]) <= row[te];
  }
  q.axial_rms = std::sqrt(q.axial_rms / double(data.rows.size()));
  q.transverse_rms = std::sqrt(q.transverse_rms / double(data.rows.size()));
  return q;
}

/// Richardson extrapolation D_inf = (N2 D2 - N1 D1)/(N2 - N1) of D(N) = D_inf + c/N.
double richardson(double n1, double d1, double n2, double d2) {
  return (n2 * d2 - n1 * d1) / (n2 - n1);
}

// Relative tolerances. Same computation, doubles printed in full (JSON): only the last bits may
// differ between two summation orders. The CSV files hold 10 significant digits: a value read
// back is within 5e-10 of it, relative.
constexpr double kSameDouble = 1e-12;
constexpr double kTenDigits = 1e-9;

void expect_rel(double got, double want, double rel, const std::string& what) {
  EXPECT_LE(std::abs(got - want), rel * std::abs(want)) << what << ": " << got << " vs " << want;
}

TEST(CliSuccess, Fig7CurvesEqualStretchAndItsFitEqualsTheRecomputedRms) {
  const std::string dir = fresh_dir("fig7");
  const std::string out = dir + "/out";
  const std::string forces = "0,100,193";  // covers the reference data (0-193 pN)
  const CommandRun r = rbc("fig7 --method discrete:150 --method continuum:2:200 --force " + forces +
                               " --out " + out + " -q",
                           dir, "fig7");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* f :
       {"fig7.png", "fig7.json", "fig7_fit.csv", "fig7_discrete_N150.csv",
        "fig7_continuum_p2_E200.csv", "experiment_suresh2005_healthy_optical_tweezers.csv",
        "experiment_mills2004_fig8_optical_tweezers.csv"})
    EXPECT_TRUE(fs::is_regular_file(out + "/" + f)) << f;
  // Both data sets in the plot, each under the name its file declares; the fit names its data.
  const std::string gp = read_text(out + "/fig7.gp");
  EXPECT_NE(gp.find("'Suresh et al. 2005, Fig. 7a/b, healthy cells D_{A}'"), std::string::npos)
      << gp;
  EXPECT_NE(gp.find("'Mills et al. 2004, Fig. 8 (D_{A}, D_{T})'"), std::string::npos) << gp;
  EXPECT_EQ(gp.find("reading"), std::string::npos) << gp;
  EXPECT_NE(r.out.find("goodness of fit against Suresh et al. 2005, Fig. 7a/b, healthy cells"),
            std::string::npos)
      << r.out;
  {  // fig7_fit.csv names each method in its first column.
    std::ifstream in(out + "/fig7_fit.csv");
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);)
      if (line.rfind('#', 0) != 0) lines.push_back(line);
    ASSERT_EQ(lines.size(), 3u);
    EXPECT_EQ(lines[0].rfind("method,axial_rms_um,", 0), 0u) << lines[0];
    EXPECT_EQ(lines[1].rfind("discrete_N150,", 0), 0u) << lines[1];
    EXPECT_EQ(lines[2].rfind("continuum_p2_E200,", 0), 0u) << lines[2];
  }
  const json summary = read_json(out + "/fig7.json");
  ASSERT_EQ(summary.size(), 2u);
  const Csv mills = read_numeric_csv(std::string(RBC_SOURCE_DIR) +
                                     "/data/suresh2005_healthy_optical_tweezers.csv");
  ASSERT_EQ(mills.rows.size(), 13u);
  const std::map<std::string, std::string> stretch_args = {
      {"discrete_N150", "--model discrete -n 150"},
      {"continuum_p2_E200", "--model continuum --order 2 --elements 200"}};
  for (const json& m : summary) {
    const std::string name = m.at("method").get<std::string>();
    SCOPED_TRACE(name);
    ASSERT_TRUE(stretch_args.count(name));
    EXPECT_TRUE(m.at("all_converged").get<bool>());
    EXPECT_EQ(m.at("points").get<int>(), 13);
    // The method's curve is `rbc stretch` at the same size and forces.
    const json pts = stretch_points(stretch_args.at(name) + " --force " + forces, dir, name);
    ASSERT_EQ(pts.size(), 3u);
    const Csv curve = read_numeric_csv(out + "/" + m.at("data").get<std::string>());
    ASSERT_EQ(curve.rows.size(), 3u);
    for (size_t k = 0; k < 3; ++k) {
      EXPECT_EQ(curve.rows[k][curve.col("force_pN")], pts[k]["force_pN"].get<double>());
      expect_rel(curve.rows[k][curve.col("axial_um")], pts[k]["axial_um"].get<double>(), kTenDigits,
                 "D_A");
      expect_rel(curve.rows[k][curve.col("transverse_um")], pts[k]["transverse_um"].get<double>(),
                 kTenDigits, "D_T");
    }
    EXPECT_EQ(m.at("vertices").get<int>(), pts[0]["vertices"].get<int>());
    // Its goodness of fit is the RMS against the Mills data, recomputed from the stretch curve.
    const Fit q = fit_to_data(mills, pts);
    expect_rel(m.at("axial_rms_um").get<double>(), q.axial_rms, kSameDouble, "D_A rms");
    expect_rel(m.at("transverse_rms_um").get<double>(), q.transverse_rms, kSameDouble, "D_T rms");
    EXPECT_EQ(m.at("axial_inside").get<int>(), q.axial_inside);
    EXPECT_EQ(m.at("transverse_inside").get<int>(), q.transverse_inside);
  }
}

TEST(CliSuccess, TradeoffRowsEqualStretchAndItsReferenceIsTheRichardsonFormula) {
  const std::string dir = fresh_dir("tradeoff");
  const std::string out = dir + "/out";
  // The Monte Carlo study runs for 1 s of wall time: only its reference (the minimiser at the
  // default tolerance, not time-dependent) is checked.
  const CommandRun r =
      rbc("tradeoff --force 50 --vertices 150,300 --elements 200 --orders 2 --mc-vertices 150 "
          "--mc-budget 1 --out " +
              out + " -q",
          dir, "tradeoff");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* f :
       {"tradeoff.csv", "tradeoff.json", "tradeoff_axial.png", "tradeoff_transverse.png",
        "mc_convergence.csv", "mc_convergence.json", "mc_convergence.png"})
    EXPECT_TRUE(fs::is_regular_file(out + "/" + f)) << f;
  const json t = read_json(out + "/tradeoff.json");
  EXPECT_EQ(t.at("force_pN").get<double>(), 50.0);
  const json& rows = t.at("rows");
  ASSERT_EQ(rows.size(), 3u);
  const std::vector<std::pair<std::string, std::string>> expected = {
      {"discrete_N150", "--model discrete -n 150"},
      {"discrete_N300", "--model discrete -n 300"},
      {"continuum_p2_E200", "--model continuum --order 2 --elements 200"}};
  for (size_t k = 0; k < rows.size(); ++k) {
    SCOPED_TRACE(expected[k].first);
    ASSERT_EQ(rows[k].at("method").get<std::string>(), expected[k].first);
    EXPECT_TRUE(rows[k].at("converged").get<bool>());
    const json pts = stretch_points(expected[k].second + " --force 50", dir, expected[k].first);
    ASSERT_EQ(pts.size(), 1u);
    expect_rel(rows[k].at("axial_um").get<double>(), pts[0]["axial_um"].get<double>(), kSameDouble,
               "D_A");
    expect_rel(rows[k].at("transverse_um").get<double>(), pts[0]["transverse_um"].get<double>(),
               kSameDouble, "D_T");
    EXPECT_EQ(rows[k].at("vertices").get<int>(), pts[0]["vertices"].get<int>());
  }
  // Reference: Richardson extrapolation of the two discrete networks, by their vertex counts;
  // its error the size of the correction; each row's error its distance from it.
  const json& ref = t.at("reference");
  const double n1 = rows[0]["vertices"].get<double>(), n2 = rows[1]["vertices"].get<double>();
  for (const char* d : {"axial_um", "transverse_um"}) {
    const double want = richardson(n1, rows[0][d].get<double>(), n2, rows[1][d].get<double>());
    expect_rel(ref.at(d).get<double>(), want, kSameDouble, std::string("reference ") + d);
    const std::string e = std::string(d).substr(0, std::string(d).find("_um")) + "_error_um";
    EXPECT_NEAR(ref.at(e).get<double>(), std::abs(want - rows[1][d].get<double>()), 1e-12) << e;
    for (const json& row : rows)
      EXPECT_NEAR(row.at(e).get<double>(), std::abs(row[d].get<double>() - want), 1e-12) << e;
  }
  // The Pareto flags follow from the rows' own (wall time, D_A error): a row is on the front
  // when every faster row has a larger error.
  for (const json& row : rows) {
    bool dominated = false;
    for (const json& other : rows)
      if (other["wall_s"].get<double>() < row["wall_s"].get<double>() &&
          other["axial_error_um"].get<double>() <= row["axial_error_um"].get<double>())
        dominated = true;
    EXPECT_EQ(row.at("pareto").get<bool>(), !dominated) << row.at("method");
  }
  // The CSV holds the same rows.
  const Csv csv = read_numeric_csv(out + "/tradeoff.csv", /*labelled=*/true);
  ASSERT_EQ(csv.rows.size(), rows.size());
  for (size_t k = 0; k < rows.size(); ++k)
    expect_rel(csv.rows[k][csv.col("axial_um")], rows[k]["axial_um"].get<double>(), kTenDigits,
               "tradeoff.csv D_A");
  // The Monte Carlo study's reference is the minimiser at 1e-3 pN: `rbc stretch` at N = 150.
  const json mc = read_json(out + "/mc_convergence.json");
  EXPECT_EQ(mc.at("reference").at("force_tolerance_pN").get<double>(), 1e-3);
  expect_rel(mc.at("reference").at("axial_um").get<double>(), rows[0]["axial_um"].get<double>(),
             kSameDouble, "Monte Carlo study reference D_A");
}

/// The first force where |D_A(order)/D_A(full) - 1| exceeds `tol` along the ladder, linearly
/// interpolated between ladder forces (the departure force stability.json documents).
std::optional<double> departure(const Csv& order, const Csv& full, double tol) {
  const size_t f = full.col("force_pN"), a = full.col("axial_um"), c = full.col("converged");
  double prev_f = 0, prev_dev = 0;
  for (size_t k = 0; k < order.rows.size() && k < full.rows.size(); ++k) {
    if (order.rows[k][c] != 1.0 || full.rows[k][c] != 1.0) break;
    const double dev = std::abs(order.rows[k][a] / full.rows[k][a] - 1.0);
    if (dev > tol)
      return k == 0 ? order.rows[k][f]
                    : prev_f + (tol - prev_dev) / (dev - prev_dev) * (order.rows[k][f] - prev_f);
    prev_f = order.rows[k][f];
    prev_dev = dev;
  }
  return std::nullopt;
}

/// The stability.json row with this study, method, metric and parameter value.
const json* stability_row(const json& rows, const std::string& study, const std::string& method,
                          const std::string& metric, double parameter_value) {
  for (const json& r : rows)
    if (r["study"] == study && r["method"] == method && r["metric"] == metric &&
        std::abs(r["parameter_value"].get<double>() - parameter_value) <=
            1e-12 * std::abs(parameter_value))
      return &r;
  ADD_FAILURE() << "no stability row " << study << " / " << method << " / " << metric;
  return nullptr;
}

TEST(CliSuccess, StabilityRowsEqualModuliStretchAndTheOrderCurves) {
  const std::string dir = fresh_dir("stability");
  const std::string out = dir + "/out";
  const CommandRun r =
      rbc("stability --vertices 100 --elements 200 --out " + out + " -q", dir, "stability");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* f :
       {"stability.csv", "stability.json", "stability_orders.png", "stability_order_2.csv",
        "stability_order_3.csv", "stability_order_4.csv", "stability_order_full.csv"})
    EXPECT_TRUE(fs::is_regular_file(out + "/" + f)) << f;
  const json rows = read_json(out + "/stability.json");
  ASSERT_TRUE(rows.is_array());
  // One stdout line per row (study | method | ...), then the outputs line.
  size_t lines = 0;
  std::stringstream ss(r.out);
  for (std::string line; std::getline(ss, line);) lines += line.find(" | ") != std::string::npos;
  EXPECT_EQ(lines, rows.size());
  // Steric sweep: the closed-form area modulus K at (q, eta) is `rbc moduli`'s paper formula
  // (uN/m = pN/um), and the stretch at 88 pN is `rbc stretch` with those steric parameters.
  struct Steric {
    const char *q, *eta, *method;
  };
  for (const Steric s : {Steric{"1", "0.005", "discrete q=1 eta=0.005"},
                         Steric{"2", "0.0005", "discrete q=2 eta=0.0005"},
                         Steric{"2", "5e-05", "discrete q=2 eta=5e-05"}}) {
    SCOPED_TRACE(s.method);
    const double eta = std::stod(s.eta);
    const CommandRun m = rbc(std::string("moduli --q ") + s.q + " --eta " + s.eta + " --json -q",
                             dir, std::string("moduli_q") + s.q + "_eta" + s.eta);
    ASSERT_EQ(m.exit_code, 0) << m.err;
    const json mj = json::parse(m.out);
    if (const json* k = stability_row(rows, "steric", s.method, "K_closed_pN_per_um", eta))
      expect_rel(k->at("value").get<double>(), mj.at("K_paper_formula_pN_per_um").get<double>(),
                 kSameDouble, "K");
    const json pts =
        stretch_points(std::string("-n 100 --force 0,88 --q ") + s.q + " --eta " + s.eta, dir,
                       std::string("stretch_q") + s.q + "_eta" + s.eta);
    ASSERT_EQ(pts.size(), 2u);
    if (const json* a = stability_row(rows, "steric", s.method, "axial_um_at_force", eta))
      expect_rel(a->at("value").get<double>(), pts[1]["axial_um"].get<double>(), kSameDouble,
                 "D_A at 88 pN");
    if (const json* t = stability_row(rows, "steric", s.method, "transverse_um_at_force", eta))
      expect_rel(t->at("value").get<double>(), pts[1]["transverse_um"].get<double>(), kSameDouble,
                 "D_T at 88 pN");
  }
  // Taylor orders: each departure force follows from the order curves written beside it
  // (10 digits: the interpolated force moves by < 1e-6 of itself).
  const Csv full = read_numeric_csv(out + "/stability_order_full.csv");
  ASSERT_FALSE(full.rows.empty());
  for (const char* order : {"2", "3", "4"}) {
    const Csv c = read_numeric_csv(out + "/stability_order_" + order + ".csv");
    ASSERT_EQ(c.rows.size(), full.rows.size()) << order;
    for (double tol : {0.01, 0.05}) {
      SCOPED_TRACE(std::string("p = ") + order + ", tolerance " + std::to_string(tol));
      const json* row = stability_row(rows, "taylor_order", std::string("continuum p=") + order,
                                      "departure_force_pN", tol);
      if (!row) continue;
      const std::optional<double> want = departure(c, full, tol);
      ASSERT_EQ(row->at("reached").get<bool>(), want.has_value());
      if (want) expect_rel(row->at("value").get<double>(), *want, 1e-6, "departure force");
    }
  }
}

TEST(CliSuccess, ReportTablesEqualTheFilesBesideItAndTheirNumbersAreRecomputed) {
  const std::string dir = fresh_dir("report");
  const std::string out = dir + "/out";
  // --quick: the smallest study the command offers (about half a minute, 10 s of it the Monte
  // Carlo study's wall-clock budget, whose time-dependent numbers are not checked).
  const CommandRun r = rbc("report --quick --out " + out + " -q", dir, "report");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* f :
       {"report.md", "fig7/fig7.json", "fig7/fig7.png", "fig7/fig7_fit.csv",
        "tradeoff/tradeoff.json", "tradeoff/tradeoff_axial.png", "tradeoff/mc_convergence.json",
        "stability/stability.json", "stability/stability_orders.png"})
    EXPECT_TRUE(fs::is_regular_file(out + "/" + f)) << f;
  const std::string md = read_text(out + "/report.md");
  const std::string fig7_md = section(md, "## Fig. 7: diameters against force");

  // Fig. 7 table: every method's RMS (2 decimals) and counts are fig7.json's.
  const json fig7 = read_json(out + "/fig7/fig7.json");
  ASSERT_FALSE(fig7.empty());
  for (const json& m : fig7) {
    const auto cells = table_rows(fig7_md, m.at("label").get<std::string>());
    ASSERT_EQ(cells.size(), 1u) << m.at("label");
    ASSERT_GE(cells[0].size(), 5u);
    EXPECT_NEAR(std::stod(cells[0][1]), m["axial_rms_um"].get<double>(), 0.005 + 1e-9);
    EXPECT_NEAR(std::stod(cells[0][3]), m["transverse_rms_um"].get<double>(), 0.005 + 1e-9);
    EXPECT_EQ(cells[0][2], std::to_string(m["axial_inside"].get<int>()) + "/" +
                               std::to_string(m["points"].get<int>()));
    EXPECT_EQ(cells[0][4], std::to_string(m["transverse_inside"].get<int>()) + "/" +
                               std::to_string(m["points"].get<int>()));
  }
  // Claim 1's evidence, the largest relative difference of continuum p = 2 from the discrete
  // model up to 200 pN (2 decimals of a percentage), recomputed from the two fig7 CSV files.
  {
    std::string discrete, p2;
    for (const json& m : fig7) {
      const std::string name = m["method"].get<std::string>();
      if (name.rfind("discrete_N", 0) == 0) discrete = m["data"].get<std::string>();
      if (name.rfind("continuum_p2_", 0) == 0) p2 = m["data"].get<std::string>();
    }
    ASSERT_FALSE(discrete.empty() || p2.empty());
    const Csv d = read_numeric_csv(out + "/fig7/" + discrete);
    const Csv c = read_numeric_csv(out + "/fig7/" + p2);
    ASSERT_EQ(d.rows.size(), c.rows.size());
    double worst_a = 0, worst_t = 0;
    for (size_t k = 0; k < d.rows.size() && d.rows[k][0] <= 200.0; ++k) {
      worst_a = std::max(worst_a, std::abs(c.rows[k][1] / d.rows[k][1] - 1));
      worst_t = std::max(worst_t, std::abs(c.rows[k][2] / d.rows[k][2] - 1));
    }
    const size_t claim = md.find("largest relative difference 0-200 pN");
    ASSERT_NE(claim, std::string::npos);
    EXPECT_NEAR(number_after(md, "D_A ", claim), 100 * worst_a, 0.005 + 1e-6);
    EXPECT_NEAR(number_after(md, "D_T ", claim), 100 * worst_t, 0.005 + 1e-6);
  }

  // Trade-off: the reference (4 decimals) is tradeoff.json's and the Richardson formula of its
  // two finest discrete networks; every row's numbers are tradeoff.json's.
  const json trade = read_json(out + "/tradeoff/tradeoff.json");
  const json& ref = trade.at("reference");
  std::ostringstream heading;
  heading << "## Speed against accuracy at " << std::fixed << std::setprecision(0)
          << trade.at("force_pN").get<double>() << " pN";
  const std::string speed_md = section(md, heading.str());
  // The trade-off table ends where the Monte Carlo subsection starts.
  const std::string trade_md = speed_md.substr(0, speed_md.find("\n### "));
  EXPECT_NEAR(number_after(speed_md, "Reference: D_A = "), ref["axial_um"].get<double>(),
              5e-5 + 1e-9);
  EXPECT_NEAR(number_after(speed_md, "um, D_T = "), ref["transverse_um"].get<double>(),
              5e-5 + 1e-9);
  std::vector<const json*> discrete_rows;
  for (const json& row : trade.at("rows"))
    if (row["method"].get<std::string>().rfind("discrete_N", 0) == 0) discrete_rows.push_back(&row);
  ASSERT_GE(discrete_rows.size(), 2u);
  std::sort(discrete_rows.begin(), discrete_rows.end(), [](const json* a, const json* b) {
    return (*a)["vertices"].get<int>() < (*b)["vertices"].get<int>();
  });
  const json& f1 = *discrete_rows[discrete_rows.size() - 2];
  const json& f2 = *discrete_rows.back();
  expect_rel(ref["axial_um"].get<double>(),
             richardson(f1["vertices"].get<double>(), f1["axial_um"].get<double>(),
                        f2["vertices"].get<double>(), f2["axial_um"].get<double>()),
             kSameDouble, "Richardson D_A");
  for (const json& row : trade.at("rows")) {
    const auto cells = table_rows(trade_md, row.at("label").get<std::string>());
    ASSERT_EQ(cells.size(), 1u) << row.at("label");
    ASSERT_GE(cells[0].size(), 6u);
    EXPECT_EQ(std::stoi(cells[0][1]), row["vertices"].get<int>());
    EXPECT_NEAR(std::stod(cells[0][2]), row["axial_um"].get<double>(), 5e-5 + 1e-9);
    EXPECT_NEAR(std::stod(cells[0][3]), row["axial_error_um"].get<double>(), 5e-5 + 1e-9);
    EXPECT_NEAR(std::stod(cells[0][4]), row["transverse_um"].get<double>(), 5e-5 + 1e-9);
    EXPECT_NEAR(std::stod(cells[0][5]), row["transverse_error_um"].get<double>(), 5e-5 + 1e-9);
  }
  // The coarsest discrete row is `rbc stretch` at that size and force.
  {
    const json& c = *discrete_rows.front();
    const std::string n = c["method"].get<std::string>().substr(std::string("discrete_N").size());
    std::ostringstream force;
    force << trade.at("force_pN").get<double>();
    const json pts = stretch_points("-n " + n + " --force " + force.str(), dir, "stretch_coarsest");
    ASSERT_EQ(pts.size(), 1u);
    expect_rel(c["axial_um"].get<double>(), pts[0]["axial_um"].get<double>(), kSameDouble,
               "coarsest discrete row D_A");
  }
  // Monte Carlo subsection: its reference D_A is mc_convergence.json's.
  const json mc = read_json(out + "/tradeoff/mc_convergence.json");
  const std::string mc_md =
      section(md, "### Time to the same accuracy: Monte Carlo against the minimiser");
  EXPECT_NEAR(number_after(mc_md, "D_A = "), mc.at("reference").at("axial_um").get<double>(),
              5e-5 + 1e-9);

  // Stability table: every row is stability.json's (4 decimals, or 2 significant digits in
  // scientific notation below 1e-3; "not reached" where the sweep did not reach it).
  const json stab = read_json(out + "/stability/stability.json");
  ASSERT_FALSE(stab.empty());
  const std::string stab_md = section(md, "## Where methods stop working");
  for (const json& row : stab) {
    const std::string study = row.at("study").get<std::string>();
    const std::string metric = row.at("metric").get<std::string>();
    const std::string method = row.at("method").get<std::string>();
    const double pv = row.at("parameter_value").get<double>();
    const std::vector<std::string>* match = nullptr;
    const auto cells = table_rows(stab_md, study);
    for (const auto& c : cells)
      if (c.size() >= 6 && c[1] == method && c[2] == row.at("parameter") && c[4] == metric &&
          std::abs(std::stod(c[3]) - pv) <= 1e-5 * std::abs(pv))
        match = &c;
    ASSERT_NE(match, nullptr) << study << " / " << method << " / " << metric << " / " << pv;
    const std::string& cell = (*match)[5];
    if (!row.at("reached").get<bool>()) {
      EXPECT_EQ(cell, "not reached") << method << " " << metric;
      continue;
    }
    const double v = row.at("value").get<double>();
    const double tol = v == 0 || std::abs(v) >= 1e-3 ? 5e-5 + 1e-9 : 0.05 * std::abs(v);
    EXPECT_NEAR(std::stod(cell), v, tol) << method << " " << metric;
  }
}

}  // namespace
