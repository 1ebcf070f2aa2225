// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/laplace_is_checkpoint.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "calibrate/infer.hpp"
#include "core/h5file.hpp"
#include "core/io.hpp"

namespace rbc {

namespace {

/// Bounds a corrupt file's declared sizes before anything is allocated from them.
constexpr long long kMaxDimension = 64, kMaxSamples = 10000000;

std::vector<double> read_column(const H5File& h, const std::string& name, size_t rows,
                                size_t cols = 1) {
  std::vector<double> v;
  const auto [r, c] = h.read(name, v);
  if (r != rows || c != cols)
    throw std::runtime_error(name + " is " + std::to_string(r) + " x " + std::to_string(c) +
                             ", expected " + std::to_string(rows) + " x " + std::to_string(cols));
  return v;
}

}  // namespace

std::vector<PosteriorInput> laplace_is_inputs(const InferenceProblem& problem) {
  static const char* const tmcmc_only[] = {"--samples",           "--chain-length", "--target-cov",
                                           "--proposal-scale",    "islands",        "max stages",
                                           "max failure fraction"};
  std::vector<PosteriorInput> out;
  for (PosteriorInput& i : posterior_inputs(problem))
    if (std::find(std::begin(tmcmc_only), std::end(tmcmc_only), i.name) == std::end(tmcmc_only))
      out.push_back(std::move(i));
  out.push_back({"--is-samples", std::to_string(problem.options().is_samples)});
  if (problem.options().is_rounds != 1)  // one round: the inputs of a run without the option
    out.push_back({"--is-rounds", std::to_string(problem.options().is_rounds)});
  return out;
}

void write_laplace_is_checkpoint(const std::string& path, const LaplaceIsCheckpoint& c,
                                 int samples) {
  const LaplaceIsState& s = c.state;
  const auto d = static_cast<hsize_t>(s.z.size());
  std::vector<double> point = {s.point.log_likelihood};
  point.insert(point.end(), s.point.gradient.data(), s.point.gradient.data() + d);
  std::vector<double> info(d * d);
  for (hsize_t i = 0; i < d; ++i)
    for (hsize_t k = 0; k < d; ++k)
      info[i * d + k] = s.point.information(Eigen::Index(i), Eigen::Index(k));
  std::vector<double> mode_state = s.point.state;
  if (mode_state.empty()) mode_state.push_back(0.0);  // one unused row: no empty datasets
  const auto n = static_cast<hsize_t>(s.draws_done);
  std::vector<double> log_like(s.draw_log_likelihood.data(), s.draw_log_likelihood.data() + n);
  if (log_like.empty()) log_like.push_back(0.0);
  std::vector<unsigned long long> offsets = {0};
  std::vector<double> values;
  for (hsize_t i = 0; i < n; ++i) {
    values.insert(values.end(), s.draw_states[i].begin(), s.draw_states[i].end());
    offsets.push_back(values.size());
  }
  if (values.empty()) values.push_back(0.0);

  TempFile tmp(path);  // removed on every path that does not commit it
  {
    H5File h = H5File::create(tmp.path(), path);
    h.write("/mode/z", s.z.data(), d, 1);
    h.write("/mode/point", point.data(), point.size(), 1);
    h.write("/mode/information", info.data(), d, d);
    h.write("/mode/state", mode_state.data(), mode_state.size(), 1);
    h.write("/draws/log_likelihood", log_like.data(), log_like.size(), 1);
    h.write("/draws/state_offsets", offsets.data(), offsets.size(), 1);
    h.write("/draws/state_values", values.data(), values.size(), 1);
    h.write_attribute("format", kStageCheckpointFormat);
    h.write_attribute("sampler", std::string(kLaplaceIsSamplerName));
    h.write_attribute("mode_found", static_cast<long long>(s.mode_found ? 1 : 0));
    h.write_attribute("newton_steps", static_cast<long long>(s.newton_steps));
    h.write_attribute("gradient_evaluations", s.gradient_evaluations);
    h.write_attribute("draws_done", static_cast<long long>(s.draws_done));
    h.write_attribute("samples", static_cast<long long>(samples));
    h.write_attribute("dimension", static_cast<long long>(d));
    h.write_attribute("state_size", static_cast<long long>(s.point.state.size()));
    h.write_attribute("forward_runs", s.counts.runs);
    h.write_attribute("forward_retried", s.counts.retried);
    h.write_attribute("forward_failed", s.counts.failed);
    h.write_attribute("forward_symmetry_broken", s.counts.symmetry_broken);
    h.write_attribute("mode_forward_runs", c.mode_forward_runs);
    h.write_attribute("sensitivity_solves", c.sensitivity_solves);
    h.write_attribute("recovery_trajectories", c.recovery_trajectories);
    write_checkpoint_inputs(h, c.inputs);
    write_checkpoint_checksum(h);
    h.close();
  }
  tmp.commit();
}

LaplaceIsCheckpoint read_laplace_is_checkpoint(const std::string& path) {
  const auto corrupt = [&](const std::string& what) {
    return std::runtime_error("checkpoint '" + path + "' is corrupt: " + what);
  };
  LaplaceIsCheckpoint out;
  LaplaceIsState& s = out.state;
  try {
    const H5File h = H5File::open_read(path, H5Seal::required);
    const long long format = h.read_attribute_int("format");
    if (format != kStageCheckpointFormat)
      throw corrupt("format version " + std::to_string(format) + " (this rbc reads version " +
                    std::to_string(kStageCheckpointFormat) + ")");
    const std::string sampler = h.read_attribute_string("sampler");
    if (sampler != kLaplaceIsSamplerName)
      throw corrupt("written by the sampler '" + sampler + "', expected '" + kLaplaceIsSamplerName +
                    "'");
    try {
      check_checkpoint_checksum(h);
      out.inputs = read_checkpoint_inputs(h);
    } catch (const std::runtime_error& e) {
      throw corrupt(e.what());
    }
    const long long mode_found = h.read_attribute_int("mode_found");
    const long long steps = h.read_attribute_int("newton_steps");
    const long long evaluations = h.read_attribute_int("gradient_evaluations");
    const long long done = h.read_attribute_int("draws_done");
    const long long samples = h.read_attribute_int("samples");
    const long long d = h.read_attribute_int("dimension");
    const long long state_size = h.read_attribute_int("state_size");
    if (mode_found != 0 && mode_found != 1) throw corrupt("mode_found is neither 0 nor 1");
    if (d < 1 || d > kMaxDimension) throw corrupt("dimension " + std::to_string(d));
    if (samples < 1 || samples > kMaxSamples) throw corrupt("samples " + std::to_string(samples));
    if (done < 0 || done > samples || (mode_found == 0 && done != 0))
      throw corrupt("draws_done " + std::to_string(done) + " of " + std::to_string(samples));
    if (steps < 0 || evaluations < 1 || evaluations < steps + 1 || steps > 1000000)
      throw corrupt(std::to_string(steps) + " Newton steps with " + std::to_string(evaluations) +
                    " gradient evaluations");
    if (state_size < 0) throw corrupt("state_size " + std::to_string(state_size));
    s.mode_found = mode_found == 1;
    s.newton_steps = static_cast<int>(steps);
    s.gradient_evaluations = evaluations;
    s.draws_done = static_cast<int>(done);
    const auto dim = static_cast<size_t>(d);
    const std::vector<double> z = read_column(h, "/mode/z", dim);
    const std::vector<double> point = read_column(h, "/mode/point", dim + 1);
    const std::vector<double> info = read_column(h, "/mode/information", dim, dim);
    std::vector<double> mode_state =
        read_column(h, "/mode/state", std::max<size_t>(size_t(state_size), 1));
    mode_state.resize(size_t(state_size));
    const auto finite = [](const std::vector<double>& v) {
      return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
    };
    if (!finite(z) || !finite(point) || !finite(info) || !finite(mode_state))
      throw corrupt("the mode search's point is not finite");
    s.z = Eigen::Map<const Eigen::VectorXd>(z.data(), Eigen::Index(d));
    s.point.ok = true;
    s.point.log_likelihood = point[0];
    s.point.gradient = Eigen::Map<const Eigen::VectorXd>(point.data() + 1, Eigen::Index(d));
    s.point.information.resize(Eigen::Index(d), Eigen::Index(d));
    for (size_t i = 0; i < dim; ++i)
      for (size_t k = 0; k < dim; ++k)
        s.point.information(Eigen::Index(i), Eigen::Index(k)) = info[i * dim + k];
    s.point.state = std::move(mode_state);
    const auto n = static_cast<size_t>(done);
    std::vector<double> log_like = read_column(h, "/draws/log_likelihood", std::max<size_t>(n, 1));
    log_like.resize(n);
    for (double l : log_like)
      if (std::isnan(l) || l == std::numeric_limits<double>::infinity())
        throw corrupt("a draw's log likelihood is neither finite nor -infinity");
    s.draw_log_likelihood = Eigen::Map<const Eigen::VectorXd>(log_like.data(), Eigen::Index(n));
    std::vector<unsigned long long> offsets;
    const auto [orows, ocols] = h.read("/draws/state_offsets", offsets);
    if (orows != n + 1 || ocols != 1) throw corrupt("/draws/state_offsets has the wrong shape");
    std::vector<double> values;
    const auto [vrows, vcols] = h.read("/draws/state_values", values);
    if (vcols != 1 || offsets.front() != 0)
      throw corrupt("/draws/state_values has the wrong shape");
    for (size_t i = 0; i < n; ++i)
      if (offsets[i + 1] < offsets[i] || offsets[i + 1] > vrows)
        throw corrupt("/draws/state_offsets out of range");
    s.draw_states.resize(n);
    for (size_t i = 0; i < n; ++i)
      s.draw_states[i].assign(values.begin() + long(offsets[i]),
                              values.begin() + long(offsets[i + 1]));
    s.counts.runs = h.read_attribute_int("forward_runs");
    s.counts.retried = h.read_attribute_int("forward_retried");
    s.counts.failed = h.read_attribute_int("forward_failed");
    s.counts.symmetry_broken = h.read_attribute_int("forward_symmetry_broken");
    out.mode_forward_runs = h.read_attribute_int("mode_forward_runs");
    out.sensitivity_solves = h.read_attribute_int("sensitivity_solves");
    out.recovery_trajectories = h.read_attribute_int("recovery_trajectories");
    if (s.counts.runs < 0 || s.counts.retried < 0 || s.counts.failed < 0 ||
        s.counts.symmetry_broken < 0 || out.mode_forward_runs < 0 || out.sensitivity_solves < 0 ||
        out.recovery_trajectories < 0)
      throw corrupt("a negative counter");
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    if (m.rfind("checkpoint '", 0) == 0) throw;
    throw std::runtime_error("checkpoint '" + path + "' cannot be read: " + m);
  }
  return out;
}

LaplaceIsCheckpoint load_laplace_is_checkpoint(const std::string& path,
                                               const InferenceProblem& problem,
                                               const std::string& what) {
  LaplaceIsCheckpoint c = read_laplace_is_checkpoint(path);
  check_posterior_inputs(c.inputs, laplace_is_inputs(problem), what);
  const auto corrupt = [&](const std::string& m) {
    return std::runtime_error("checkpoint '" + path + "' is corrupt: " + m);
  };
  const LaplaceIsState& s = c.state;
  const int d = problem.prior().dimension();
  if (s.z.size() != d)
    throw corrupt("a point of " + std::to_string(s.z.size()) + " coordinates for " +
                  std::to_string(d) + " parameters");
  if (s.draws_done > problem.options().is_samples)
    throw corrupt(std::to_string(s.draws_done) + " draws evaluated of " +
                  std::to_string(problem.options().is_samples));
  const size_t state_size = problem.state_size();
  const auto check_state = [&](const WarmState& w, const std::string& whose) {
    if (!w.empty() && w.size() != state_size)
      throw corrupt("warm state of " + whose + " has " + std::to_string(w.size()) +
                    " values, the forward model " + std::to_string(state_size));
  };
  check_state(s.point.state, "the mode search's point");
  for (int i = 0; i < s.draws_done; ++i)
    check_state(s.draw_states[size_t(i)], "draw " + std::to_string(i));
  return c;
}

std::string laplace_is_position(const LaplaceIsState& s, int samples) {
  if (!s.mode_found)
    return s.newton_steps == 0 ? "mode search, after the first gradient evaluation"
                               : "mode search, after Newton step " + std::to_string(s.newton_steps);
  return "importance sampling, " + std::to_string(s.draws_done) + " of " + std::to_string(samples) +
         " draws evaluated";
}

}  // namespace rbc
