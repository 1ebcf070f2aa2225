// SPDX-License-Identifier: GPL-3.0-or-later
// Stage checkpoints (calibrate/stage_checkpoint.hpp): a TMCMC run continued from the file
// written after stage k ends exactly where the straight run ends (samples, log-likelihoods,
// warm states, evidence, counters, stage log; timing aside), on 1 or 2 threads; a file with a
// changed byte, another format version or inconsistent arrays is refused, and a checkpoint of
// other inputs is refused naming each input that differs.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <stdexcept>
#include <string>

#include "calibrate/stage_checkpoint.hpp"
#include "calibrate/stage_checkpoint_arrays.hpp"
#include "calibrate/tmcmc.hpp"
#include "test_output.hpp"

namespace rbc {
namespace {

namespace fs = std::filesystem;

/// A 2-D Gaussian likelihood whose value and warm state also depend on the parent's warm state
/// (as the forward model's Newton iterations do), so a continued run that lost or altered a
/// warm state would drift from the straight run.
class WarmGaussian final : public Likelihood {
 public:
  int dimension() const override { return 2; }
  LikelihoodValue evaluate(std::span<const double> t, const WarmState& warm,
                           WarmState* out) const override {
    const double memory = warm.empty() ? 0.0 : warm[0];
    LikelihoodValue v;
    v.log_likelihood = -0.5 * (std::pow((t[0] - 0.3) / 0.05, 2) + std::pow((t[1] + 0.2) / 0.1, 2)) +
                       1e-3 * std::sin(memory);
    v.retried = t[0] > 0.9;  // some counters that are not all zero
    if (out) *out = {t[0] * t[1] + 0.5 * memory, t[0] + t[1], static_cast<double>(warm.size())};
    return v;
  }
};

PriorBox box() {
  return PriorBox{{-1.0, -1.0}, {1.0, 1.0}};
}

TmcmcOptions options() {
  TmcmcOptions o;
  o.samples = 40;
  o.chain_length = 2;
  o.islands = 2;
  o.seed = 11;
  return o;
}

const std::vector<PosteriorInput> kInputs = {{"--seed", "11"}, {"--samples", "40"}};

void expect_same_result(const TmcmcResult& a, const TmcmcResult& b, const std::string& what) {
  EXPECT_EQ(a.status, b.status) << what;
  ASSERT_EQ(a.samples.rows(), b.samples.rows()) << what;
  EXPECT_TRUE(a.samples == b.samples) << what;  // exact, element by element
  EXPECT_TRUE(a.log_likelihood == b.log_likelihood) << what;
  EXPECT_EQ(a.states, b.states) << what;
  EXPECT_EQ(a.log_evidence, b.log_evidence) << what;
  EXPECT_EQ(a.log_evidence_sd, b.log_evidence_sd) << what;
  EXPECT_EQ(a.counts.runs, b.counts.runs) << what;
  EXPECT_EQ(a.counts.retried, b.counts.retried) << what;
  EXPECT_EQ(a.counts.failed, b.counts.failed) << what;
  ASSERT_EQ(a.stages.size(), b.stages.size()) << what;
  for (size_t j = 0; j < a.stages.size(); ++j) {
    EXPECT_EQ(a.stages[j].stage, b.stages[j].stage) << what << " stage " << j;
    EXPECT_EQ(a.stages[j].beta, b.stages[j].beta) << what << " stage " << j;
    EXPECT_EQ(a.stages[j].cov, b.stages[j].cov) << what << " stage " << j;
    EXPECT_EQ(a.stages[j].log_mean_weight, b.stages[j].log_mean_weight) << what << " stage " << j;
    EXPECT_EQ(a.stages[j].acceptance, b.stages[j].acceptance) << what << " stage " << j;
    EXPECT_EQ(a.stages[j].unique_fraction, b.stages[j].unique_fraction) << what << " stage " << j;
    EXPECT_EQ(a.stages[j].forward_runs, b.stages[j].forward_runs) << what << " stage " << j;
  }
}

/// A straight run writing dir/stage_K.h5 after every stage K.
TmcmcResult straight_run(const fs::path& dir) {
  const WarmGaussian like;
  const PriorBox prior = box();
  TmcmcContinuation c;
  c.checkpoint = [&](const SamplerState& s) {
    write_stage_checkpoint((dir / ("stage_" + std::to_string(s.stage) + ".h5")).string(), kInputs,
                           s);
  };
  return run_tmcmc(like, prior, options(), omp_executor(prior, like, 1), {}, c);
}

TEST(StageCheckpoint, ContinuedRunEqualsTheStraightRunExactly) {
  const fs::path dir = testing::fresh_output_dir("stage_checkpoint_continue");
  const WarmGaussian like;
  const PriorBox prior = box();
  const TmcmcResult straight = straight_run(dir);
  const int last = static_cast<int>(straight.stages.size()) - 1;
  ASSERT_GE(last, 3) << "the test needs a run of several stages";
  // Without checkpoints the sampler gives the same run (writing them changes nothing).
  expect_same_result(straight, run_tmcmc(like, prior, options(), omp_executor(prior, like, 1)),
                     "no checkpoints");
  for (int k : {0, 1, last - 1, last}) {
    const StageCheckpoint cp =
        read_stage_checkpoint((dir / ("stage_" + std::to_string(k) + ".h5")).string());
    EXPECT_EQ(cp.inputs, kInputs);
    ASSERT_EQ(cp.state.stage, k);
    EXPECT_EQ(cp.state.schedule.back(), straight.stages[k].beta);
    for (int threads : {1, 2}) {
      TmcmcContinuation c;
      c.resume = &cp.state;
      std::vector<int> handed_out;
      c.checkpoint = [&](const SamplerState& s) { handed_out.push_back(s.stage); };
      const TmcmcResult continued =
          run_tmcmc(like, prior, options(), omp_executor(prior, like, threads), {}, c);
      expect_same_result(
          straight, continued,
          "from stage " + std::to_string(k) + ", " + std::to_string(threads) + " threads");
      // The continued run hands out the stages after k only.
      ASSERT_EQ(static_cast<int>(handed_out.size()), last - k);
      if (!handed_out.empty()) {
        EXPECT_EQ(handed_out.front(), k + 1);
      }
    }
  }
}

TEST(StageCheckpoint, ContinuingAnotherSamplersStateIsRefused) {
  const fs::path dir = testing::fresh_output_dir("stage_checkpoint_foreign_state");
  straight_run(dir);
  const WarmGaussian like;
  const PriorBox prior = box();
  StageCheckpoint cp = read_stage_checkpoint((dir / "stage_1.h5").string());
  TmcmcOptions other = options();
  other.islands = 4;  // the state has 2 islands
  TmcmcContinuation c;
  c.resume = &cp.state;
  EXPECT_THROW(run_tmcmc(like, prior, other, omp_executor(prior, like, 1), {}, c),
               std::invalid_argument);
  other = options();
  other.samples = 50;
  EXPECT_THROW(run_tmcmc(like, prior, other, omp_executor(prior, like, 1), {}, c),
               std::invalid_argument);
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

/// Rewrites one root attribute (long long) of an HDF5 file in place.
void set_int_attribute(const std::string& path, const char* name, long long value) {
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hid_t a = H5Aopen(f, name, H5P_DEFAULT);
  ASSERT_GE(a, 0);
  EXPECT_GE(H5Awrite(a, H5T_NATIVE_LLONG, &value), 0);
  H5Aclose(a);
  H5Fclose(f);
}

/// Rewrites the first value of a double dataset in place.
void set_first_value(const std::string& path, const char* dataset, double value) {
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hid_t d = H5Dopen2(f, dataset, H5P_DEFAULT);
  ASSERT_GE(d, 0);
  std::vector<double> v(static_cast<size_t>(H5Sget_simple_extent_npoints(H5Dget_space(d))));
  H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
  v[0] = value;
  EXPECT_GE(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), 0);
  H5Dclose(d);
  H5Fclose(f);
}

/// Seals an edited file again, as a file another rbc wrote would be sealed: "fnv1a64 HEX16 bytes
/// N" after the seal's first line, over the bytes after the 512-byte user block (written out here
/// from the format core/h5file.hpp describes, not with the code under test).
void reseal(const std::string& path) {
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  ASSERT_GT(bytes.size(), 512u);
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (std::size_t i = 512; i < bytes.size(); ++i) {
    h ^= static_cast<unsigned char>(bytes[i]);
    h *= 0x100000001b3ull;
  }
  const std::string first = "rbc sealed HDF5 file\n";
  ASSERT_EQ(bytes.compare(0, first.size(), first), 0);
  char line[80];
  const int n = std::snprintf(line, sizeof line, "fnv1a64 %016llx bytes %zu\n",
                              static_cast<unsigned long long>(h), bytes.size() - 512);
  std::fill(bytes.begin() + static_cast<std::ptrdiff_t>(first.size()), bytes.begin() + 512, '\0');
  std::copy(line, line + n, bytes.begin() + static_cast<std::ptrdiff_t>(first.size()));
  std::ofstream(path, std::ios::binary) << bytes;
}

TEST(StageCheckpoint, ChangedCorruptOrMissingFilesAreRefused) {
  const fs::path dir = testing::fresh_output_dir("stage_checkpoint_corrupt");
  straight_run(dir);
  const std::string good = (dir / "stage_2.h5").string();
  ASSERT_NO_THROW(read_stage_checkpoint(good));
  auto copy = [&](const std::string& name) {
    const std::string p = (dir / name).string();
    fs::copy_file(good, p, fs::copy_options::overwrite_existing);
    return p;
  };
  const auto refused = [](const std::string& path) {
    return error_of([&] { read_stage_checkpoint(path); });
  };
  {  // an edited stage number
    const std::string p = copy("edited_stage.h5");
    set_int_attribute(p, "stage", 1);
    const std::string e = refused(p);
    EXPECT_NE(e.find("is corrupt"), std::string::npos) << e;
    EXPECT_NE(e.find("checksum"), std::string::npos) << e;
  }
  {  // one sample moved
    const std::string p = copy("edited_theta.h5");
    set_first_value(p, "/population/theta", 0.123);
    EXPECT_NE(refused(p).find("checksum"), std::string::npos) << refused(p);
  }
  {  // another format version
    const std::string p = copy("format.h5");
    set_int_attribute(p, "format", kStageCheckpointFormat + 1);
    reseal(p);  // as another rbc would have written it
    EXPECT_NE(refused(p).find("format version"), std::string::npos) << refused(p);
  }
  // A flipped byte in the stored data of each dataset (found with H5Dget_offset: contiguous
  // storage), not through HDF5: the file still opens, the checksum catches it.
  for (const char* dataset :
       {"/population/theta", "/population/log_likelihood", "/population/state_values",
        "/schedule/stage_log", "/accumulators/log_evidence_island"}) {
    const std::string p = copy("flipped.h5");
    haddr_t at = HADDR_UNDEF;
    {
      const hid_t f = H5Fopen(p.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
      const hid_t d = H5Dopen2(f, dataset, H5P_DEFAULT);
      at = H5Dget_offset(d);
      H5Dclose(d);
      H5Fclose(f);
    }
    ASSERT_NE(at, HADDR_UNDEF) << dataset;
    std::fstream g(p, std::ios::in | std::ios::out | std::ios::binary);
    g.seekg(static_cast<std::streamoff>(at) + 1);
    char c = 0;
    g.read(&c, 1);
    c = static_cast<char>(c ^ 0x10);
    g.seekp(static_cast<std::streamoff>(at) + 1);
    g.write(&c, 1);
    g.close();
    const std::string e = refused(p);
    EXPECT_NE(e.find("checksum"), std::string::npos) << dataset << ": " << e;
  }
  {  // truncated, missing
    const std::string p = copy("truncated.h5");
    fs::resize_file(p, fs::file_size(p) / 2);
    EXPECT_NE(refused(p).find(p), std::string::npos) << refused(p);
    EXPECT_NE(refused((dir / "missing.h5").string()).find("missing.h5"), std::string::npos);
  }
}

TEST(StageCheckpoint, OtherInputsAreNamedInTheRefusal) {
  const std::vector<PosteriorInput> stored = {
      {"--seed", "1"}, {"--samples", "40"}, {"--method", "continuum:2:200"}};
  EXPECT_NO_THROW(check_posterior_inputs(stored, stored, "--resume d"));
  const std::string e = error_of([&] {
    check_posterior_inputs(stored,
                           {{"--seed", "2"}, {"--samples", "40"}, {"--method", "continuum:2:400"}},
                           "--resume d");
  });
  EXPECT_EQ(e.rfind("--resume d: ", 0), 0u) << e;
  EXPECT_NE(e.find("--seed (checkpoint 1, this run 2)"), std::string::npos) << e;
  EXPECT_NE(e.find("--method (checkpoint continuum:2:200, this run continuum:2:400)"),
            std::string::npos)
      << e;
  EXPECT_EQ(e.find("--samples"), std::string::npos) << "an equal input is not named: " << e;
  EXPECT_NE(posterior_fingerprint(stored),
            posterior_fingerprint({stored[1], stored[0], stored[2]}));
}

/// A small consistent set of arrays (the fuzz target's starting point too).
StageCheckpointArrays valid_arrays() {
  StageCheckpointArrays a;
  a.sampler = "tmcmc";
  a.stage = 2;
  a.samples = 3;
  a.dimension = 2;
  a.theta = {{0.1, 0.2, 0.3, 0.4, 0.5, 0.6}, 3, 2};
  a.log_likelihood = {{-1, -2, -INFINITY}, 3, 1};
  a.state_index = {{0, 1, 0}, 3, 1};
  a.state_offsets = {{0, 2, 2}, 3, 1};
  a.state_values = {{7, 8}, 2, 1};
  a.schedule = {{0, 0.5, 1}, 3, 1};
  a.stage_log = {
      {0, 0, 0, 0, 0, 1, 3, 0.1, 1, 0.5, 1, -1, 0.5, 0.6, 6, 0.2, 2, 1, 1, -1, 0.5, 0.6, 9, 0.3},
      3,
      kStageLogColumns};
  a.accumulators = {{"log_evidence_island", {{-1, -INFINITY}, 2, 1}},
                    {"delta_method_variance", {{0.1}, 1, 1}}};
  a.runs = 9;
  return a;
}

TEST(StageCheckpointArrays, InconsistentArraysAreRefused) {
  ASSERT_NO_THROW(check_stage_checkpoint_arrays(valid_arrays()));
  std::map<std::string, std::function<void(StageCheckpointArrays&)>> edits = {
      {"unknown sampler", [](auto& a) { a.sampler = "smc"; }},
      {"theta NaN", [](auto& a) { a.theta.values[3] = NAN; }},
      {"theta short", [](auto& a) { a.theta.values.pop_back(); }},
      {"theta shape", [](auto& a) { a.theta.cols = 3; }},
      {"log-likelihood +inf", [](auto& a) { a.log_likelihood.values[0] = INFINITY; }},
      {"state index out of range", [](auto& a) { a.state_index.values[1] = 2; }},
      {"offsets decrease",
       [](auto& a) {
         a.state_offsets.values = {0, 2, 1};
       }},
      {"offsets past the values",
       [](auto& a) {
         a.state_offsets.values = {0, 2, 3};
       }},
      {"schedule not from 0",
       [](auto& a) {
         a.schedule.values[0] = 0.1;
         a.stage_log.values[1] = 0.1;
       }},
      // The schedule edits keep the stage log in step, so only the schedule's own check can
      // refuse them.
      {"schedule decreasing",
       [](auto& a) {
         a.schedule.values[2] = 0.4;
         a.stage_log.values[2 * kStageLogColumns + 1] = 0.4;
       }},
      {"schedule above 1",
       [](auto& a) {
         a.schedule.values[2] = 1.5;
         a.stage_log.values[2 * kStageLogColumns + 1] = 1.5;
       }},
      {"stage log beta", [](auto& a) { a.stage_log.values[kStageLogColumns + 1] = 0.4; }},
      {"stage log numbering", [](auto& a) { a.stage_log.values[kStageLogColumns] = 2; }},
      {"runs disagree", [](auto& a) { a.runs = 10; }},
      {"failed above runs", [](auto& a) { a.failed = 10; }},
      {"stage without its row", [](auto& a) { a.stage = 3; }},
      {"island NaN", [](auto& a) { a.accumulators[0].second.values[0] = NAN; }},
      {"variance negative", [](auto& a) { a.accumulators[1].second.values[0] = -1; }},
      {"accumulator missing", [](auto& a) { a.accumulators.pop_back(); }},
      {"huge population", [](auto& a) { a.samples = 1LL << 40; }},
  };
  for (const auto& [name, edit] : edits) {
    StageCheckpointArrays a = valid_arrays();
    edit(a);
    EXPECT_THROW(check_stage_checkpoint_arrays(a), std::runtime_error) << name;
  }
}

}  // namespace
}  // namespace rbc
