// SPDX-License-Identifier: GPL-3.0-or-later
// Checkpoint and restart of MC runs: a resumed run continues the same chain bit for bit; a
// checkpoint of another network, a corrupt or truncated file is refused; no half file is left.
#include <gtest/gtest.h>
#include <omp.h>

#include <filesystem>
#include <fstream>

#include "core/h5file.hpp"
#include "core/rest_shape.hpp"
#include "discrete/mc_checkpoint.hpp"
#include "discrete/mc_run.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace {

namespace fs = std::filesystem;

struct Dir {
  fs::path path;
  explicit Dir(const std::string& name) : path(fs::path(RBC_BINARY_DIR) / "test_output" / name) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
};

Network small_network(int n) {
  RestShapeOptions o;
  o.target_vertices = n;
  return build_network(make_rest_shape(o), NetworkParameters{});
}

McRunSetup setup_for_test() {
  McRunSetup s;
  s.force_pN = 30;
  s.multipliers = {0.5, -0.2};
  s.sampler.temperature_K = 300;
  s.sampler.seed = 99;
  s.sampler.streams = 2;
  // One chain: these tests edit its state (tests/discrete/test_mc_chains.cpp: several).
  s.sampler.chains = 1;
  s.sampler.adapt_sweeps = 6;  // the restart falls inside the adaptive phase
  s.sample_every = 2;
  s.reference_axial_um = 7.9;
  return s;
}

TEST(McCheckpoint, ResumedRunReproducesTheUninterruptedChainBitForBit) {
  const Network net = small_network(150);
  const Dir dir("mc_checkpoint_restart");
  const McRunSetup setup = setup_for_test();
  McRun whole(net, setup, net.rest);
  whole.advance(14);

  McRun first(net, setup, net.rest);
  const std::string file = (dir.path / "chain.h5").string();
  // "Killed" after sweep 5: the after-sweep hook writes the checkpoint and stops the run.
  first.advance(14, [&](const McRun& r) {
    if (r.sampler().sweeps_done() < 5) return true;
    write_mc_checkpoint(file, net, McCheckpoint{r.setup(), r.state(), r.series()});
    return false;
  });
  ASSERT_EQ(first.sampler().sweeps_done(), 5);
  const McCheckpoint cp = read_mc_checkpoint(file, net);
  EXPECT_EQ(cp.chain.sweep, 5);
  EXPECT_EQ(cp.setup.sampler.seed, setup.sampler.seed);
  EXPECT_EQ(cp.setup.multipliers.area_pN_per_um, setup.multipliers.area_pN_per_um);
  // Resume with a different thread count: the chain depends on the streams only.
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  McRun resumed(net, cp.setup, cp.chain, cp.series);
  resumed.advance(14);
  omp_set_num_threads(saved);

  const McChainState a = whole.state(), b = resumed.state();
  EXPECT_EQ((a.x - b.x).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(a.rng_state, b.rng_state);
  EXPECT_EQ(a.step_um, b.step_um);
  EXPECT_EQ(a.sweep, b.sweep);
  ASSERT_EQ(whole.series().size(), resumed.series().size());
  for (size_t i = 0; i < whole.series().size(); ++i) {
    EXPECT_EQ(whole.series()[i].sweep, resumed.series()[i].sweep);
    EXPECT_EQ(whole.series()[i].acceptance, resumed.series()[i].acceptance);
    EXPECT_EQ(whole.series()[i].step_um, resumed.series()[i].step_um);
    EXPECT_EQ(whole.series()[i].axial_um, resumed.series()[i].axial_um);
  }
  // The chain really moved, so equality is not trivial.
  EXPECT_GT((a.x - net.rest).cwiseAbs().maxCoeff(), 0.0);
}

TEST(McCheckpoint, CheckpointOfAnotherNetworkIsRefused) {
  const Network net = small_network(150);
  const Dir dir("mc_checkpoint_mismatch");
  McRun run(net, setup_for_test(), net.rest);
  run.advance(2);
  const std::string file = (dir.path / "chain.h5").string();
  write_mc_checkpoint(file, net, McCheckpoint{run.setup(), run.state(), run.series()});
  // Another vertex count.
  const Network other = small_network(300);
  EXPECT_THROW(read_mc_checkpoint(file, other), std::invalid_argument);
  // Same topology, rest positions moved by one ulp-scale amount: the fingerprint differs.
  TriMesh moved{net.rest, net.topo};
  moved.x(0, 3) += 1e-9;
  const Network shifted = build_network(moved, NetworkParameters{});
  try {
    read_mc_checkpoint(file, shifted);
    FAIL() << "a checkpoint of another network was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("another network"), std::string::npos) << e.what();
  }
  // Same mesh, other bending energy: the chain sampled a different distribution.
  NetworkParameters dihedral;
  dihedral.bending_model = BendingModel::dihedral;
  EXPECT_THROW(read_mc_checkpoint(file, build_network(TriMesh{net.rest, net.topo}, dihedral)),
               std::invalid_argument);
  EXPECT_NO_THROW(read_mc_checkpoint(file, net));
}

TEST(McCheckpoint, CorruptOrMissingFilesAreRefusedWithTheirName) {
  const Network net = small_network(150);
  const Dir dir("mc_checkpoint_corrupt");
  const std::string garbage = (dir.path / "garbage.h5").string();
  {
    std::ofstream f(garbage);
    f << "not an HDF5 file\n";
  }
  auto refused = [&](const std::string& path) {
    try {
      read_mc_checkpoint(path, net);
      return std::string("accepted");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
  };
  EXPECT_NE(refused(garbage).find(garbage), std::string::npos);
  EXPECT_NE(refused((dir.path / "missing.h5").string()).find("missing.h5"), std::string::npos);
  // A valid checkpoint truncated half-way (a torn copy) is refused.
  McRun run(net, setup_for_test(), net.rest);
  run.advance(2);
  const std::string good = (dir.path / "good.h5").string();
  write_mc_checkpoint(good, net, McCheckpoint{run.setup(), run.state(), run.series()});
  const auto size = fs::file_size(good);
  const std::string torn = (dir.path / "torn.h5").string();
  fs::copy_file(good, torn);
  fs::resize_file(torn, size / 2);
  EXPECT_NE(refused(torn), "accepted");
  // An HDF5 file that is not a checkpoint (no format attribute) is refused.
  const std::string other = (dir.path / "other.h5").string();
  {
    H5File h = H5File::create(other);
    const double v[3] = {1, 2, 3};
    h.write("/values", v, 3, 1);
  }
  EXPECT_NE(refused(other).find("format"), std::string::npos) << refused(other);
}

// A checkpoint whose sweep count was edited, written with a checksum that matches the edit (the
// writer computes it), is refused: its sweep count disagrees with its stored time series. The
// edited file differs from the real one in the sweep count (and checksum) only.
TEST(McCheckpoint, EditedSweepCountWithAValidChecksumIsRefused) {
  const Network net = small_network(150);
  const Dir dir("mc_checkpoint_edited_sweep");
  McRun run(net, setup_for_test(), net.rest);
  run.advance(7);  // samples at sweeps 2, 4, 6
  const std::string real = (dir.path / "real.h5").string();
  write_mc_checkpoint(real, net, McCheckpoint{run.setup(), run.state(), run.series()});
  McCheckpoint cp = read_mc_checkpoint(real, net);
  ASSERT_EQ(cp.chain.sweep, 7);
  ASSERT_EQ(cp.series.size(), 3u);
  for (long long sweep : {1'000'000'000'000'000LL, 8LL, 5LL}) {
    cp.chains[0].sweep = sweep;
    const std::string edited = (dir.path / "edited.h5").string();
    write_mc_checkpoint(edited, net, cp);
    {
      const H5File a = H5File::open_read(real), b = H5File::open_read(edited);
      EXPECT_EQ(b.read_attribute_int("sweep"), sweep);
      EXPECT_EQ(a.read_attribute_int("series_rows"), b.read_attribute_int("series_rows"));
      EXPECT_EQ(a.read_attribute_string("seed"), b.read_attribute_string("seed"));
    }
    try {
      read_mc_checkpoint(edited, net);
      ADD_FAILURE() << "sweep " << sweep << " accepted with 3 samples every 2 sweeps";
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("is corrupt: sweep count " + std::to_string(sweep) +
                          " disagrees with the stored time series: 3 samples, one every 2 "
                          "sweeps"),
                std::string::npos)
          << what;
    }
  }
  cp.chains[0].sweep = 6;  // consistent: 3 samples every 2 sweeps
  const std::string six = (dir.path / "six.h5").string();
  write_mc_checkpoint(six, net, cp);
  EXPECT_EQ(read_mc_checkpoint(six, net).chain.sweep, 6);
}

TEST(McCheckpoint, FailedWriteLeavesNoFileBehind) {
  const Network net = small_network(150);
  const Dir dir("mc_checkpoint_atomic");
  McRun run(net, setup_for_test(), net.rest);
  run.advance(1);
  McCheckpoint cp{run.setup(), run.state(), run.series()};
  cp.chain.rng_state[1].resize(10);  // inconsistent state: the writer throws mid-way
  const std::string file = (dir.path / "chain.h5").string();
  EXPECT_ANY_THROW(write_mc_checkpoint(file, net, cp));
  EXPECT_FALSE(fs::exists(file));
  for (const auto& e : fs::directory_iterator(dir.path))
    ADD_FAILURE() << "left behind: " << e.path();
  // An existing good checkpoint survives a failed overwrite untouched.
  const McCheckpoint good{run.setup(), run.state(), run.series()};
  write_mc_checkpoint(file, net, good);
  EXPECT_ANY_THROW(write_mc_checkpoint(file, net, cp));
  EXPECT_EQ(read_mc_checkpoint(file, net).chain.x, good.chain.x);
}

}  // namespace
}  // namespace rbc
