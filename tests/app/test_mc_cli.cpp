// SPDX-License-Identifier: GPL-3.0-or-later
// `rbc mc` from the command line: the thread decision recorded in --json and run.json (checked
// on its inputs, never by timing), --force spelled as every other command spells it, and the
// snapshots' displacement fields: displacement_um the same quantity as in the stretch shapes
// (|x - X|), displacement_x_um its x component.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_run.hpp"
#include "core/h5file.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::CliRun;
using testing::fresh_output_dir;
using testing::run_rbc;

std::string quoted(const fs::path& p) {
  std::string q = "'";  // (appended: GCC 12's -Wrestrict misfires on "'" + string)
  q += p.string();
  q += '\'';
  return q;
}

json read_json(const fs::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

std::vector<double> read_dataset(const fs::path& file, const std::string& name) {
  std::vector<double> v;
  H5File::open_read(file.string()).read(name, v);
  return v;
}

TEST(McCli, ThreadDecisionIsRecordedInJsonAndRunJson) {
  // Two threads available, N = 150: the sweeps run on one (a second does not pay at this size),
  // and both outputs say so with the reason.
  const fs::path dir = fresh_output_dir("mc_cli_threads");
  const CliRun r =
      run_rbc("mc -n 150 --force 20 --sweeps 40 -q --json --no-picture --out " + quoted(dir), 2);
  ASSERT_EQ(r.exit_code, 0) << r.all();
  const json printed = json::parse(r.out);
  const json manifest = read_json(dir / "run.json");
  const json summary = read_json(dir / "mc_summary.json");
  for (const json* j : {&printed, &manifest, &summary}) {
    ASSERT_TRUE(j->contains("threads")) << j->dump(2);
    const json& t = j->at("threads");
    EXPECT_EQ(t.at("used").get<int>(), 1) << t.dump();
    EXPECT_EQ(t.at("requested").get<int>(), 2) << t.dump();
    EXPECT_EQ(t.at("reason").get<std::string>().rfind("1: a second thread does not pay", 0), 0u)
        << t.dump();
  }
  // One thread available: that is the reason.
  const CliRun one = run_rbc("mc -n 150 --force 20 --sweeps 10 -q --json", 1);
  ASSERT_EQ(one.exit_code, 0) << one.all();
  EXPECT_EQ(json::parse(one.out).at("threads").at("reason"),
            "1: one thread requested (OMP_NUM_THREADS)");
}

TEST(McCli, ForceHasNoShortForm) {
  // -f is no command's short form for --force: refused with exit 2 before any work.
  const CliRun r = run_rbc("mc -n 150 -f 20 --sweeps 10 -q");
  EXPECT_EQ(r.exit_code, 2) << r.all();
  EXPECT_NE(r.err.find("-f"), std::string::npos) << r.all();
  EXPECT_EQ(run_rbc("mc -n 150 --force 20 --sweeps 10 -q").exit_code, 0);
}

TEST(McCli, SnapshotDisplacementIsTheQuantityStretchShapesCallSo) {
  // From the rest shape, snapshot 0 holds X; the last one x. displacement_um must be |x - X|
  // per vertex (what the stretch shapes call displacement_um) and displacement_x_um x - X's
  // x component.
  const fs::path dir = fresh_output_dir("mc_cli_displacement");
  const CliRun r = run_rbc(
      "mc -n 150 --start rest --sweeps 30 --snapshot-every 30 -q "
      "--no-picture --out " +
      quoted(dir / "mc"));
  ASSERT_EQ(r.exit_code, 0) << r.all();
  const fs::path first = dir / "mc" / "mc_snapshot_00000000.h5",
                 last = dir / "mc" / "mc_snapshot_00000030.h5";
  const std::vector<double> X = read_dataset(first, "/mesh/positions_um"),
                            x = read_dataset(last, "/mesh/positions_um"),
                            u = read_dataset(last, "/vertex/displacement_um"),
                            ux = read_dataset(last, "/vertex/displacement_x_um"),
                            u0 = read_dataset(first, "/vertex/displacement_um");
  ASSERT_EQ(X.size(), x.size());
  const std::size_t n = X.size() / 3;
  ASSERT_EQ(u.size(), n);
  ASSERT_EQ(ux.size(), n);
  EXPECT_EQ(*std::max_element(u0.begin(), u0.end()), 0.0);  // snapshot 0 is the rest shape
  double moved = 0, off_axis = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = x[3 * i] - X[3 * i], dy = x[3 * i + 1] - X[3 * i + 1],
                 dz = x[3 * i + 2] - X[3 * i + 2];
    EXPECT_NEAR(u[i], std::sqrt(dx * dx + dy * dy + dz * dz), 1e-12) << "vertex " << i;
    EXPECT_NEAR(ux[i], dx, 1e-12) << "vertex " << i;
    moved = std::max(moved, u[i]);
    off_axis = std::max(off_axis, u[i] - std::abs(ux[i]));
  }
  EXPECT_GT(moved, 0.0);     // the chain moved
  EXPECT_GT(off_axis, 0.0);  // and the two fields differ

  // The stretch shapes: the same field name for the same quantity, |x - X| from the same rest
  // shape.
  const CliRun s = run_rbc("stretch -n 150 --force 20 -q --out " + quoted(dir / "stretch"));
  ASSERT_EQ(s.exit_code, 0) << s.all();
  fs::path shape;
  for (const auto& e : fs::directory_iterator(dir / "stretch"))
    if (e.path().extension() == ".h5" && e.path().filename().string().rfind("shape_", 0) == 0)
      shape = e.path();
  ASSERT_FALSE(shape.empty());
  const std::vector<double> xs = read_dataset(shape, "/mesh/positions_um"),
                            us = read_dataset(shape, "/vertex/displacement_um");
  ASSERT_EQ(xs.size(), X.size());
  ASSERT_EQ(us.size(), n);
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = xs[3 * i] - X[3 * i], dy = xs[3 * i + 1] - X[3 * i + 1],
                 dz = xs[3 * i + 2] - X[3 * i + 2];
    EXPECT_NEAR(us[i], std::sqrt(dx * dx + dy * dy + dz * dz), 1e-9) << "vertex " << i;
  }
}

}  // namespace
}  // namespace rbc
