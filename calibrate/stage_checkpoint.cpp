// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/stage_checkpoint.hpp"

#include <charconv>
#include <fstream>
#include <iterator>
#include <map>
#include <stdexcept>

#include "calibrate/infer.hpp"
#include "calibrate/stage_checkpoint_arrays.hpp"
#include "core/fnv1a.hpp"
#include "core/h5file.hpp"
#include "core/io.hpp"
#include "core/mirror_symmetry.hpp"

namespace rbc {

namespace {

constexpr const char* kChecksumAttribute = "content_checksum";
constexpr const char* kInputPrefix = "input ";

/// Shortest text that reads back as the same double.
std::string exact(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string join(const std::vector<std::string>& items, const std::string& sep) {
  std::string s;
  for (const auto& i : items) s += (s.empty() ? "" : sep) + i;
  return s;
}

std::vector<std::string> split_lines(const std::string& s) {
  std::vector<std::string> out;
  size_t b = 0;
  while (b <= s.size()) {
    const size_t e = std::min(s.find('\n', b), s.size());
    if (e > b) out.push_back(s.substr(b, e - b));
    b = e + 1;
  }
  return out;
}

template <class T>
CheckpointTable<T> read_table(const H5File& h, const std::string& name) {
  CheckpointTable<T> t;
  const auto [rows, cols] = h.read(name, t.values);
  t.rows = rows;
  t.cols = cols;
  return t;
}

/// The stage log's row of a stage (stage_checkpoint_arrays.hpp, the column order).
std::vector<double> stage_row(const StageInfo& s) {
  return {double(s.stage),        s.beta,       s.cov,
          s.log_mean_weight,      s.acceptance, s.unique_fraction,
          double(s.forward_runs), s.elapsed_s};
}

/// A check of the shared pieces that failed (the caller adds the file's name).
struct CheckpointMismatch : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace

void write_checkpoint_inputs(H5File& h, const std::vector<PosteriorInput>& inputs) {
  std::vector<std::string> input_names;
  for (const auto& i : inputs) {
    h.write_attribute(kInputPrefix + i.name, i.value);
    input_names.push_back(i.name);
  }
  h.write_attribute("inputs", join(input_names, "\n"));
  h.write_attribute("fingerprint", hex_digits(posterior_fingerprint(inputs)));
}

std::vector<PosteriorInput> read_checkpoint_inputs(const H5File& h) {
  std::vector<PosteriorInput> inputs;
  for (const std::string& name : split_lines(h.read_attribute_string("inputs")))
    inputs.push_back({name, h.read_attribute_string(kInputPrefix + name)});
  if (h.read_attribute_string("fingerprint") != hex_digits(posterior_fingerprint(inputs)))
    throw CheckpointMismatch("the fingerprint does not match the inputs stored with it");
  return inputs;
}

void write_checkpoint_checksum(H5File& h) {
  h.write_attribute(kChecksumAttribute, hex_digits(h.content_checksum(kChecksumAttribute)));
}

void check_checkpoint_checksum(const H5File& h) {
  const std::string stored = h.read_attribute_string(kChecksumAttribute);
  const std::string actual = hex_digits(h.content_checksum(kChecksumAttribute));
  if (stored != actual)
    throw CheckpointMismatch("its contents do not match the checksum written with them (stored " +
                             stored + ", computed " + actual + ")");
}

std::string checkpoint_sampler(const std::string& path) {
  try {
    const H5File h = H5File::open_read(path, H5Seal::required);
    return h.read_attribute_string("sampler");
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("checkpoint '" + path + "' cannot be read: " + e.what());
  }
}

std::string data_file_digest(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("data file '" + path + "' cannot be read");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  Fnv1a f;
  f.add(bytes.data(), bytes.size());
  return "fnv1a-64 " + hex_digits(f.h) + ", " + std::to_string(bytes.size()) + " bytes";
}

std::vector<PosteriorInput> posterior_inputs(const InferenceProblem& problem) {
  const InferOptions& o = problem.options();
  std::vector<std::string> params, priors;
  for (Parameter p : o.parameters) params.push_back(to_string(p));
  for (const PriorRange& r : o.prior_ranges())
    priors.push_back(to_string(r.parameter) + "=" + exact(r.lower) + ":" + exact(r.upper));
  const ForwardParameters& f = o.fixed;
  const TmcmcOptions& s = o.sampler;
  std::vector<PosteriorInput> inputs;
  const std::vector<std::string> paths = o.data_paths();
  if (paths.size() == 1) {
    inputs.push_back({"--data-file contents", data_file_digest(paths.front())});
    const std::string stem = data_file_stem(paths.front());
    if (o.extra_uncertainty_for(stem) != o.extra_uncertainty_um)
      inputs.push_back({"--extra-uncertainty " + stem, exact(o.extra_uncertainty_for(stem))});
  } else {
    // Several files: the list (stems, in order) and each file's contents and added extra
    // uncertainty, so a resume with other files, in another order or changed, is refused.
    std::vector<std::string> stems;
    for (const auto& p : paths) stems.push_back(data_file_stem(p));
    inputs.push_back({"--data-file list", join(stems, ",")});
    for (const auto& p : paths) {
      const std::string stem = data_file_stem(p);
      inputs.push_back({"--data-file " + stem + " contents", data_file_digest(p)});
      inputs.push_back({"--extra-uncertainty " + stem, exact(o.extra_uncertainty_for(stem))});
    }
  }
  if (!o.per_experiment.empty()) {
    std::vector<std::string> per;
    for (Parameter p : o.per_experiment) per.push_back(to_string(p));
    inputs.push_back({"--per-experiment", join(per, ",")});
  }
  std::vector<PosteriorInput> rest = {
      {"--extra-uncertainty", exact(o.extra_uncertainty_um)},
      {"--method", o.method.name()},
      {"--force-tolerance", exact(o.force_tolerance_pN)},
      {"--symmetry", to_string(o.symmetry)},
      {"--params", join(params, ",")},
      {"--prior", join(priors, ",")},
      {"fixed parameters", "persistence_nm=" + exact(f.persistence_nm) +
                               ",lmax_nm=" + exact(f.lmax_nm) + ",kappa_J=" + exact(f.kappa_J) +
                               ",contact_fraction=" + exact(f.contact_fraction) +
                               ",sigma_scale=" + exact(o.fixed_sigma_scale)},
      {"--samples", std::to_string(s.samples)},
      {"--chain-length", std::to_string(s.chain_length)},
      {"--target-cov", exact(s.target_cov)},
      {"--proposal-scale", exact(s.proposal_scale)},
      {"islands", std::to_string(s.islands)},
      {"max stages", std::to_string(s.max_stages)},
      {"max failure fraction", exact(s.max_failure_fraction)},
      {"--seed", std::to_string(s.seed)},
  };
  inputs.insert(inputs.end(), rest.begin(), rest.end());
  if (problem.has_recovery())
    inputs.push_back({"--recovery-elements", std::to_string(o.recovery_model.elements)});
  return inputs;
}

std::uint64_t posterior_fingerprint(const std::vector<PosteriorInput>& inputs) {
  Fnv1a f;
  for (const auto& i : inputs) {
    f.add(i.name);
    f.add(i.value);
  }
  return f.h;
}

void write_stage_checkpoint(const std::string& path, const std::vector<PosteriorInput>& inputs,
                            const SamplerState& s) {
  const auto n = static_cast<hsize_t>(s.theta.rows()), d = static_cast<hsize_t>(s.theta.cols());
  // The warm-state pool: each distinct state once (resampled siblings whose chains stayed at
  // the parent share it), found by content hash and confirmed by comparison.
  std::vector<unsigned long long> index(n), offsets = {0};
  std::vector<double> values;
  std::multimap<std::uint64_t, unsigned long long> seen;  // hash -> pool entry
  std::vector<const WarmState*> entries;
  for (hsize_t i = 0; i < n; ++i) {
    const WarmState& w = s.states[i];
    Fnv1a f;
    f.add(w.data(), w.size() * sizeof(double));
    const std::uint64_t key = f.h ^ w.size();
    bool found = false;
    for (auto [it, end] = seen.equal_range(key); it != end; ++it)
      if (*entries[it->second] == w) {
        index[i] = it->second;
        found = true;
        break;
      }
    if (found) continue;
    index[i] = entries.size();
    seen.emplace(key, entries.size());
    entries.push_back(&w);
    values.insert(values.end(), w.begin(), w.end());
    offsets.push_back(values.size());
  }
  if (values.empty()) values.push_back(0.0);  // one unused row: HDF5 datasets are not empty here

  std::vector<double> theta(n * d);  // row-major
  for (hsize_t i = 0; i < n; ++i)
    for (hsize_t k = 0; k < d; ++k) theta[i * d + k] = s.theta(Eigen::Index(i), Eigen::Index(k));
  std::vector<double> log_like(s.log_likelihood.data(), s.log_likelihood.data() + n);
  std::vector<double> stage_log;
  for (const StageInfo& info : s.stages) {
    const std::vector<double> row = stage_row(info);
    stage_log.insert(stage_log.end(), row.begin(), row.end());
  }

  TempFile tmp(path);  // removed on every path that does not commit it
  {
    H5File h = H5File::create(tmp.path(), path);
    h.write("/population/theta", theta.data(), n, d);
    h.write("/population/log_likelihood", log_like.data(), n, 1);
    h.write("/population/state_index", index.data(), n, 1);
    h.write("/population/state_offsets", offsets.data(), offsets.size(), 1);
    h.write("/population/state_values", values.data(), values.size(), 1);
    h.write("/schedule/exponent", s.schedule.data(), s.schedule.size(), 1);
    h.write("/schedule/stage_log", stage_log.data(), s.stages.size(), kStageLogColumns);
    std::vector<std::string> names;
    for (const auto& [name, v] : s.accumulators) {
      h.write("/accumulators/" + name, v.data(), v.size(), 1);
      names.push_back(name);
    }
    h.write_attribute("accumulators", join(names, "\n"));
    h.write_attribute("format", kStageCheckpointFormat);
    h.write_attribute("sampler", s.sampler);
    h.write_attribute("stage", static_cast<long long>(s.stage));
    h.write_attribute("samples", static_cast<long long>(n));
    h.write_attribute("dimension", static_cast<long long>(d));
    h.write_attribute("forward_runs", s.counts.runs);
    h.write_attribute("forward_retried", s.counts.retried);
    h.write_attribute("forward_failed", s.counts.failed);
    h.write_attribute("forward_symmetry_broken", s.counts.symmetry_broken);
    write_checkpoint_inputs(h, inputs);
    write_checkpoint_checksum(h);
    h.close();
  }
  tmp.commit();
}

StageCheckpoint read_stage_checkpoint(const std::string& path) {
  const auto corrupt = [&](const std::string& what) {
    return std::runtime_error("checkpoint '" + path + "' is corrupt: " + what);
  };
  StageCheckpoint out;
  StageCheckpointArrays a;
  try {
    const H5File h = H5File::open_read(path, H5Seal::required);
    const long long format = h.read_attribute_int("format");
    if (format != kStageCheckpointFormat)
      throw corrupt("format version " + std::to_string(format) + " (this rbc reads version " +
                    std::to_string(kStageCheckpointFormat) + ")");
    // Another sampler's layout (laplace-is, calibrate/laplace_is_checkpoint.hpp) has other
    // datasets: named here rather than as a missing one.
    if (const std::string sampler = h.read_attribute_string("sampler"); sampler != "tmcmc")
      throw corrupt("written by the sampler '" + sampler + "', expected 'tmcmc'");
    try {
      check_checkpoint_checksum(h);
      out.inputs = read_checkpoint_inputs(h);
    } catch (const CheckpointMismatch& e) {
      throw corrupt(e.what());
    }
    a.sampler = h.read_attribute_string("sampler");
    a.stage = h.read_attribute_int("stage");
    a.samples = h.read_attribute_int("samples");
    a.dimension = h.read_attribute_int("dimension");
    a.runs = h.read_attribute_int("forward_runs");
    a.retried = h.read_attribute_int("forward_retried");
    a.failed = h.read_attribute_int("forward_failed");
    a.symmetry_broken = h.read_attribute_int("forward_symmetry_broken");
    a.theta = read_table<double>(h, "/population/theta");
    a.log_likelihood = read_table<double>(h, "/population/log_likelihood");
    a.state_index = read_table<unsigned long long>(h, "/population/state_index");
    a.state_offsets = read_table<unsigned long long>(h, "/population/state_offsets");
    a.state_values = read_table<double>(h, "/population/state_values");
    a.schedule = read_table<double>(h, "/schedule/exponent");
    a.stage_log = read_table<double>(h, "/schedule/stage_log");
    for (const std::string& name : split_lines(h.read_attribute_string("accumulators")))
      a.accumulators.emplace_back(name, read_table<double>(h, "/accumulators/" + name));
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    if (m.rfind("checkpoint '", 0) == 0) throw;
    // H5File names the file itself: "HDF5 file 'PATH': has no attribute stage".
    throw std::runtime_error("checkpoint '" + path + "' cannot be read: " + m);
  }
  try {
    check_stage_checkpoint_arrays(a);
  } catch (const std::runtime_error& e) {
    throw corrupt(e.what());
  }
  SamplerState& s = out.state;
  s.sampler = a.sampler;
  s.stage = static_cast<int>(a.stage);
  const auto n = static_cast<Eigen::Index>(a.samples), d = static_cast<Eigen::Index>(a.dimension);
  s.theta.resize(n, d);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index k = 0; k < d; ++k) s.theta(i, k) = a.theta.values[size_t(i * d + k)];
  s.log_likelihood = Eigen::Map<const Eigen::VectorXd>(a.log_likelihood.values.data(), n);
  s.states.resize(size_t(n));
  for (size_t i = 0; i < size_t(n); ++i) {
    const unsigned long long e = a.state_index.values[i];
    const auto b = a.state_values.values.begin();
    s.states[i].assign(b + long(a.state_offsets.values[e]),
                       b + long(a.state_offsets.values[e + 1]));
  }
  s.schedule = a.schedule.values;
  for (size_t j = 0; j < a.stage_log.rows; ++j) {
    const double* r = a.stage_log.values.data() + j * kStageLogColumns;
    StageInfo info;
    info.stage = static_cast<int>(r[0]);
    info.beta = r[1];
    info.cov = r[2];
    info.log_mean_weight = r[3];
    info.acceptance = r[4];
    info.unique_fraction = r[5];
    info.forward_runs = static_cast<long long>(r[6]);
    info.elapsed_s = r[7];
    s.stages.push_back(info);
  }
  for (const auto& [name, table] : a.accumulators) s.accumulators.emplace_back(name, table.values);
  s.counts.runs = a.runs;
  s.counts.retried = a.retried;
  s.counts.failed = a.failed;
  s.counts.symmetry_broken = a.symmetry_broken;
  return out;
}

void check_posterior_inputs(const std::vector<PosteriorInput>& stored,
                            const std::vector<PosteriorInput>& current, const std::string& what) {
  std::vector<std::string> differences;
  const auto find = [](const std::vector<PosteriorInput>& list, const std::string& name) {
    for (const auto& i : list)
      if (i.name == name) return &i;
    return static_cast<const PosteriorInput*>(nullptr);
  };
  for (const auto& c : current) {
    const PosteriorInput* s = find(stored, c.name);
    if (!s)
      differences.push_back(c.name + " (not in the checkpoint; this run has " + c.value + ")");
    else if (s->value != c.value)
      differences.push_back(c.name + " (checkpoint " + s->value + ", this run " + c.value + ")");
  }
  for (const auto& s : stored)
    if (!find(current, s.name))
      differences.push_back(s.name + " (checkpoint " + s.value + ", unknown to this rbc)");
  if (!differences.empty())
    throw std::invalid_argument(what +
                                ": the checkpoint belongs to another inference; differing "
                                "inputs: " +
                                join(differences, "; "));
}

SamplerState load_stage_checkpoint(const std::string& path, const InferenceProblem& problem,
                                   const std::string& what) {
  StageCheckpoint cp = read_stage_checkpoint(path);
  check_posterior_inputs(cp.inputs, posterior_inputs(problem), what);
  const SamplerState& s = cp.state;
  const auto corrupt = [&](const std::string& m) {
    return std::runtime_error("checkpoint '" + path + "' is corrupt: " + m);
  };
  const int n = problem.options().sampler.samples, d = problem.prior().dimension();
  if (s.theta.rows() != n || s.theta.cols() != d)
    throw corrupt("population of " + std::to_string(s.theta.rows()) + " x " +
                  std::to_string(s.theta.cols()) + " for " + std::to_string(n) + " samples of " +
                  std::to_string(d) + " parameters");
  if (static_cast<int>(s.accumulator("log_evidence_island").size()) !=
      problem.options().sampler.islands)
    throw corrupt("accumulators of another island count");
  const size_t state_size = problem.state_size();
  std::vector<double> theta(size_t(d), 0.0);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < d; ++k) theta[size_t(k)] = s.theta(i, k);
    if (!problem.prior().contains(theta))
      throw corrupt("sample " + std::to_string(i) + " lies outside the prior box");
    if (!s.states[size_t(i)].empty() && s.states[size_t(i)].size() != state_size)
      throw corrupt("warm state of sample " + std::to_string(i) + " has " +
                    std::to_string(s.states[size_t(i)].size()) + " values, the forward model " +
                    std::to_string(state_size));
  }
  return std::move(cp.state);
}

}  // namespace rbc
