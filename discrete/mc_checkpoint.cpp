// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/mc_checkpoint.hpp"

#include <gsl/gsl_rng.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <numeric>
#include <stdexcept>
#include <tuple>

#include "core/fnv1a.hpp"
#include "core/h5file.hpp"
#include "core/io.hpp"
#include "discrete/mc_checkpoint_arrays.hpp"

namespace rbc {

namespace {

static_assert(kMcCheckpointSeriesColumns == kMcSampleColumns);

// 2: penalty_scale; bending model in the fingerprint. 3: the adaptation schedule's origin
// (planned_sweeps, adapt_fraction) next to its absolute length adapt_sweeps. 4: a checksum of
// every dataset and attribute (content_checksum), so a changed byte is refused, never resumed.
// 5: the links (rest lengths, WLC density), the steric term and the bead patch in the
// fingerprint, so a chain resumes only on the energy it sampled. 6: the HMC sampler's state and
// options. 7: independent chains (McOptions::chains), each in its own group.
constexpr long long kFormat = 7;
/// Where the checksum of everything else in the file is kept.
constexpr const char* kChecksumAttribute = "content_checksum";

/// Refuses a checkpoint of another format version, or one whose contents no longer match the
/// checksum they were written with.
void check_format(const H5File& h, const std::string& path) {
  const long long f = h.read_attribute_int("format");
  if (f == kFormat) {
    const std::string stored = h.read_attribute_string(kChecksumAttribute);
    const std::string actual = hex_digits(h.content_checksum(kChecksumAttribute));
    if (stored != actual)
      throw std::runtime_error("checkpoint '" + path +
                               "' is corrupt: its contents do not match the checksum written "
                               "with them (stored " +
                               stored + ", computed " + actual + ")");
    return;
  }
  if (f >= 1 && f < kFormat)
    throw std::runtime_error("checkpoint '" + path + "' has format version " + std::to_string(f) +
                             ", written by an older rbc; this rbc reads version " +
                             std::to_string(kFormat) + " only (rerun the chain to resume it)");
  throw std::runtime_error("checkpoint '" + path + "' is corrupt: unknown format version " +
                           std::to_string(f) + " (this rbc reads version " +
                           std::to_string(kFormat) + ")");
}

}  // namespace

std::uint64_t network_fingerprint(const Network& net) {
  Fnv1a f;
  const long long n = net.topo.num_vertices, nf = net.topo.num_faces();
  f.add(&n, sizeof n);
  f.add(&nf, sizeof nf);
  f.add(net.topo.faces.data(), sizeof(int) * std::size_t(net.topo.faces.size()));
  f.add(net.rest.data(), sizeof(double) * std::size_t(net.rest.size()));
  // The bending model and constants: a chain is only valid on the energy it sampled.
  const int model = static_cast<int>(net.bending_model);
  const double bending[] = {net.bending.kappa_pNum, net.bending.h0_per_um, net.dihedral_kb_pNum};
  f.add(&model, sizeof model);
  f.add(bending, sizeof bending);
  // The links, the steric term and the bead patch (the model options of the front ends).
  f.add(net.lbar_um.data(), sizeof(double) * std::size_t(net.lbar_um.size()));
  const int expansion = static_cast<int>(net.wlc.expansion);
  const double links_steric[] = {net.wlc.prefactor_pN_per_um, net.wlc.x0, net.steric.q,
                                 net.steric.eta, net.steric_C_pN_per_um};
  f.add(&expansion, sizeof expansion);
  f.add(links_steric, sizeof links_steric);
  f.add(net.wlc.taylor.data(), sizeof(double) * net.wlc.taylor.size());
  f.add(net.patch.vertex.data(), sizeof(int) * net.patch.vertex.size());
  f.add(net.patch.share.data(), sizeof(double) * net.patch.share.size());
  return f.h;
}

void write_mc_checkpoint(const std::string& path, const Network& net, const McCheckpoint& cp) {
  const std::vector<McChainState> one_chain{cp.chain};
  const std::vector<std::vector<McSample>> one_series{cp.series};
  const auto& chains = cp.chains.empty() ? one_chain : cp.chains;
  const auto& series = cp.chains.empty() ? one_series : cp.chain_series;
  if (chains.size() != std::size_t(cp.setup.sampler.chains) || series.size() != chains.size())
    throw std::invalid_argument("checkpoint of " + std::to_string(chains.size()) +
                                " chain states and " + std::to_string(series.size()) +
                                " series for a run of " + std::to_string(cp.setup.sampler.chains) +
                                " chains");
  TempFile tmp(path);  // removed on every path that does not commit it
  {
    H5File h = H5File::create(tmp.path(), path);
    const std::size_t bytes = chains[0].rng_state.empty() ? 0 : chains[0].rng_state[0].size();
    const std::size_t words = (bytes + 7) / 8;
    std::vector<unsigned long long> sweeps, rows_count;
    std::vector<double> steps;
    for (std::size_t k = 0; k < chains.size(); ++k) {
      const McChainState& c = chains[k];
      const std::string group = "/chain_" + std::to_string(k);
      h.write(group + "/positions_um", c.x.data(), hsize_t(c.x.cols()), 3);
      std::vector<unsigned long long> packed(c.rng_state.size() * words, 0ull);
      for (std::size_t s = 0; s < c.rng_state.size(); ++s) {
        if (c.rng_state[s].size() != bytes)
          throw std::invalid_argument("RNG streams of unequal state size");
        std::memcpy(packed.data() + s * words, c.rng_state[s].data(), bytes);
      }
      h.write(group + "/rng_state", packed.data(), hsize_t(c.rng_state.size()), hsize_t(words));
      std::vector<double> rows;
      for (const McSample& s : series[k]) {
        const std::vector<double> r = to_row(s);
        rows.insert(rows.end(), r.begin(), r.end());
      }
      if (series[k].empty()) rows.assign(kMcSampleColumns, 0.0);  // HDF5 has no empty dataset
      h.write(group + "/series", rows.data(), hsize_t(series[k].empty() ? 1 : series[k].size()),
              kMcSampleColumns);
      if (cp.setup.sampler.algorithm == McAlgorithm::hmc) {
        if (c.mass_reference.cols() != c.x.cols())
          throw std::invalid_argument("HMC chain state without its mass reference");
        h.write(group + "/mass_reference_um", c.mass_reference.data(),
                hsize_t(c.mass_reference.cols()), 3);
        if (c.mass_reference_sum.size()) {
          if (c.mass_reference_sum.cols() != c.x.cols())
            throw std::invalid_argument("HMC chain state's position sum has the wrong size");
          h.write(group + "/mass_reference_sum_um", c.mass_reference_sum.data(),
                  hsize_t(c.mass_reference_sum.cols()), 3);
        }
      }
      sweeps.push_back(static_cast<unsigned long long>(c.sweep));
      rows_count.push_back(series[k].size());
      steps.push_back(c.step_um);
    }
    h.write("/chain_sweeps", sweeps.data(), hsize_t(chains.size()), 1);
    h.write("/chain_series_rows", rows_count.data(), hsize_t(chains.size()), 1);
    h.write("/chain_steps", steps.data(), hsize_t(chains.size()), 1);
    h.write_attribute("format", kFormat);
    h.write_attribute("chains", static_cast<long long>(chains.size()));
    // The run's sweep (the fewest of a chain) and its samples over all chains.
    h.write_attribute("sweep",
                      static_cast<long long>(*std::min_element(sweeps.begin(), sweeps.end())));
    h.write_attribute("series_rows", static_cast<long long>(std::accumulate(
                                         rows_count.begin(), rows_count.end(), 0ull)));
    h.write_attribute("fingerprint", hex_digits(network_fingerprint(net)));
    h.write_attribute("vertices", static_cast<long long>(net.topo.num_vertices));
    h.write_attribute("bending_model", to_string(net.bending_model));
    h.write_attribute("faces", static_cast<long long>(net.topo.num_faces()));
    h.write_attribute("rng_type", std::string(gsl_rng_mt19937->name));
    h.write_attribute("rng_bytes", static_cast<long long>(bytes));
    const McRunSetup& u = cp.setup;
    h.write_attribute("temperature_K", u.sampler.temperature_K);
    h.write_attribute("force_pN", u.force_pN);
    h.write_attribute("lambda_area_pN_per_um", u.multipliers.area_pN_per_um);
    h.write_attribute("lambda_volume_pN_per_um2", u.multipliers.volume_pN_per_um2);
    h.write_attribute("seed", std::to_string(u.sampler.seed));
    h.write_attribute("streams", static_cast<long long>(u.sampler.streams));
    h.write_attribute("initial_step_um", u.sampler.initial_step_um);
    h.write_attribute("adapt_sweeps", static_cast<long long>(u.sampler.adapt_sweeps));
    h.write_attribute("target_acceptance", u.sampler.target_acceptance);
    h.write_attribute("adapt_gain", u.sampler.adapt_gain);
    h.write_attribute("sample_every", static_cast<long long>(u.sample_every));
    h.write_attribute("penalty_scale", u.penalty_scale);
    h.write_attribute("reference_axial_um", u.reference_axial_um);
    h.write_attribute("reference_transverse_um", u.reference_transverse_um);
    h.write_attribute("planned_sweeps", cp.schedule.planned_sweeps);
    h.write_attribute("adapt_fraction", cp.schedule.adapt_fraction);
    std::vector<int> mobile = u.sampler.mobile;
    if (mobile.empty()) mobile.push_back(-1);  // -1: every vertex moves
    h.write("/mobile", mobile.data(), hsize_t(mobile.size()), 1);
    h.write_attribute("sampler", to_string(u.sampler.algorithm));
    if (u.sampler.algorithm == McAlgorithm::hmc) {
      const HmcOptions& m = u.sampler.hmc;
      h.write_attribute("hmc_step", m.step);
      h.write_attribute("hmc_trajectory_time", m.trajectory_time);
      h.write_attribute("hmc_jitter", m.jitter);
      h.write_attribute("hmc_target_acceptance", m.target_acceptance);
      h.write_attribute("hmc_adapt_gain", m.adapt_gain);
      h.write_attribute("hmc_max_steps", static_cast<long long>(m.max_steps));
      h.write_attribute("hmc_projected_mass", static_cast<long long>(m.projected_mass));
      h.write_attribute("hmc_mass_shift_fraction", m.mass_shift_fraction);
      // A file without hmc_area_volume holds a chain with penalties.
      h.write_attribute("hmc_area_volume", to_string(m.area_volume));
      // Written for the thermal reference only; absent means equilibrium.
      if (m.mass_reference != HmcMassReference::equilibrium) {
        h.write_attribute("hmc_mass_reference", to_string(m.mass_reference));
        // Per chain: 1 when its matrix is the thermal mean's, 0 while (or, after a failed
        // rebuild, since) it is the start's.
        std::vector<int> at_mean;
        for (const McChainState& c : chains) at_mean.push_back(c.mass_at_thermal_mean ? 1 : 0);
        h.write("/chain_mass_at_thermal_mean", at_mean.data(), hsize_t(at_mean.size()), 1);
      }
    }
    h.write_attribute(kChecksumAttribute, hex_digits(h.content_checksum(kChecksumAttribute)));
    h.close();
  }
  tmp.commit();
}

McCheckpointNetwork peek_mc_checkpoint_network(const std::string& path) {
  const H5File h = H5File::open_read(path, H5Seal::required);
  check_format(h, path);
  McCheckpointNetwork n;
  n.vertices = static_cast<int>(h.read_attribute_int("vertices"));
  try {
    n.bending_model = bending_model_from_string(h.read_attribute_string("bending_model"));
    n.algorithm = mc_algorithm_from_string(h.read_attribute_string("sampler"));
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error("checkpoint '" + path + "' is corrupt: " + e.what());
  }
  return n;
}

McCheckpoint read_mc_checkpoint(const std::string& path, const Network& net) {
  const H5File h = H5File::open_read(path, H5Seal::required);
  auto corrupt = [&](const std::string& what) {
    return std::runtime_error("checkpoint '" + path + "' is corrupt: " + what);
  };
  check_format(h, path);
  const long long nv = h.read_attribute_int("vertices"), nf = h.read_attribute_int("faces");
  const std::string fp = h.read_attribute_string("fingerprint");
  if (nv != net.topo.num_vertices || nf != net.topo.num_faces() ||
      fp != hex_digits(network_fingerprint(net)))
    throw std::invalid_argument("checkpoint '" + path + "' belongs to another network (" +
                                std::to_string(nv) + " vertices, " + std::to_string(nf) +
                                " faces, fingerprint " + fp + "; this network has " +
                                std::to_string(net.topo.num_vertices) + " vertices, " +
                                std::to_string(net.topo.num_faces()) + " faces, fingerprint " +
                                hex_digits(network_fingerprint(net)) + ")");
  const long long chain_count = h.read_attribute_int("chains");
  if (chain_count < 1 || chain_count > kMaxMcChains)
    throw corrupt("chain count " + std::to_string(chain_count) + " is not in [1, " +
                  std::to_string(kMaxMcChains) + "]");
  std::vector<unsigned long long> sweeps, rows_count;
  std::vector<double> steps;
  const auto sweeps_shape = h.read("/chain_sweeps", sweeps);
  const auto rows_shape = h.read("/chain_series_rows", rows_count);
  const auto steps_shape = h.read("/chain_steps", steps);
  for (const auto& shape : {sweeps_shape, rows_shape, steps_shape})
    if (shape.first != hsize_t(chain_count) || shape.second != 1)
      throw corrupt("per-chain counts are not " + std::to_string(chain_count) + " x 1");
  if (sweeps.size() != std::size_t(chain_count) || rows_count.size() != sweeps.size() ||
      steps.size() != sweeps.size())
    throw corrupt("per-chain counts have the wrong length");
  if (h.read_attribute_int("sweep") !=
          static_cast<long long>(*std::min_element(sweeps.begin(), sweeps.end())) ||
      h.read_attribute_int("series_rows") !=
          static_cast<long long>(std::accumulate(rows_count.begin(), rows_count.end(), 0ull)))
    throw corrupt("the run's sweep count or sample count disagrees with its chains'");
  if (h.read_attribute_string("rng_type") != gsl_rng_mt19937->name)
    throw corrupt("RNG type is not " + std::string(gsl_rng_mt19937->name));
  const long long rng_bytes = h.read_attribute_int("rng_bytes");
  if (rng_bytes != static_cast<long long>(gsl_rng_mt19937->size))
    throw corrupt("RNG state has " + std::to_string(rng_bytes) + " bytes, mt19937 needs " +
                  std::to_string(gsl_rng_mt19937->size));
  McCheckpoint cp;
  for (long long k = 0; k < chain_count; ++k) {
    // Every array is read, then checked as a whole (discrete/mc_checkpoint_arrays.hpp), then
    // used.
    const std::string group = "/chain_" + std::to_string(k);
    McCheckpointArrays a;
    a.vertices = nv;
    std::tie(a.positions_rows, a.positions_cols) = h.read(group + "/positions_um", a.positions_um);
    std::tie(a.rng_rows, a.rng_cols) = h.read(group + "/rng_state", a.rng_state);
    a.rng_bytes = rng_bytes;
    a.streams = h.read_attribute_int("streams");
    std::tie(a.series_rows, a.series_cols) = h.read(group + "/series", a.series);
    if (sweeps[std::size_t(k)] > (1ull << 62) || rows_count[std::size_t(k)] > (1ull << 62))
      throw corrupt("chain " + std::to_string(k) + ": sweep or sample count out of range");
    a.series_count = static_cast<long long>(rows_count[std::size_t(k)]);
    a.sweep = static_cast<long long>(sweeps[std::size_t(k)]);
    a.sample_every = h.read_attribute_int("sample_every");
    h.read("/mobile", a.mobile);
    try {
      check_mc_checkpoint_arrays(a);
    } catch (const std::runtime_error& e) {
      throw corrupt(std::string(e.what()) + " (chain " + std::to_string(k) + ")");
    }
    McChainState chain;
    chain.x = Eigen::Map<const Eigen::Matrix3Xd>(a.positions_um.data(), 3, nv);
    for (std::size_t s = 0; s < a.rng_rows; ++s) {
      const auto* first =
          reinterpret_cast<const unsigned char*>(a.rng_state.data() + s * a.rng_cols);
      chain.rng_state.emplace_back(first, first + a.rng_bytes);
    }
    chain.sweep = a.sweep;
    chain.step_um = steps[std::size_t(k)];
    if (!(chain.step_um > 0) || !std::isfinite(chain.step_um))
      throw corrupt("chain " + std::to_string(k) + ": step out of range");
    std::vector<McSample> series;
    for (long long i = 0; i < a.series_count; ++i)
      series.push_back(sample_from_row(a.series.data() + i * kMcSampleColumns));
    if (k == 0 && !(a.mobile.size() == 1 && a.mobile[0] == -1)) cp.setup.sampler.mobile = a.mobile;
    cp.chains.push_back(std::move(chain));
    cp.chain_series.push_back(std::move(series));
  }
  McRunSetup& u = cp.setup;
  u.sampler.temperature_K = h.read_attribute_double("temperature_K");
  u.force_pN = h.read_attribute_double("force_pN");
  u.multipliers.area_pN_per_um = h.read_attribute_double("lambda_area_pN_per_um");
  u.multipliers.volume_pN_per_um2 = h.read_attribute_double("lambda_volume_pN_per_um2");
  try {
    u.sampler.seed = std::stoul(h.read_attribute_string("seed"));
  } catch (const std::logic_error&) {
    throw corrupt("seed is not a number");
  }
  u.sampler.streams = static_cast<int>(h.read_attribute_int("streams"));
  u.sampler.initial_step_um = h.read_attribute_double("initial_step_um");
  u.sampler.adapt_sweeps = static_cast<int>(h.read_attribute_int("adapt_sweeps"));
  u.sampler.target_acceptance = h.read_attribute_double("target_acceptance");
  u.sampler.adapt_gain = h.read_attribute_double("adapt_gain");
  u.sample_every = static_cast<int>(h.read_attribute_int("sample_every"));
  u.penalty_scale = h.read_attribute_double("penalty_scale");
  u.reference_axial_um = h.read_attribute_double("reference_axial_um");
  u.reference_transverse_um = h.read_attribute_double("reference_transverse_um");
  cp.schedule.planned_sweeps = h.read_attribute_int("planned_sweeps");
  cp.schedule.adapt_fraction = h.read_attribute_double("adapt_fraction");
  if (cp.schedule.planned_sweeps < 0 ||
      !(cp.schedule.adapt_fraction == -1.0 ||
        (cp.schedule.adapt_fraction >= 0 && cp.schedule.adapt_fraction < 1)))
    throw corrupt("adaptation schedule out of range");
  u.sampler.chains = static_cast<int>(chain_count);
  try {
    u.sampler.algorithm = mc_algorithm_from_string(h.read_attribute_string("sampler"));
  } catch (const std::invalid_argument& e) {
    throw corrupt(e.what());
  }
  if (u.sampler.algorithm == McAlgorithm::hmc) {
    for (long long k = 0; k < chain_count; ++k) {
      std::vector<double> reference;
      const auto [rows, cols] =
          h.read("/chain_" + std::to_string(k) + "/mass_reference_um", reference);
      if (static_cast<long long>(rows) != nv || cols != 3 ||
          !Eigen::Map<const Eigen::VectorXd>(reference.data(), Eigen::Index(reference.size()))
               .allFinite())
        throw corrupt("HMC mass reference of chain " + std::to_string(k) + " is not " +
                      std::to_string(nv) + " x 3 finite positions");
      cp.chains[std::size_t(k)].mass_reference =
          Eigen::Map<const Eigen::Matrix3Xd>(reference.data(), 3, nv);
      const std::string sum_name = "/chain_" + std::to_string(k) + "/mass_reference_sum_um";
      if (h.has(sum_name)) {
        std::vector<double> sum;
        const auto [srows, scols] = h.read(sum_name, sum);
        if (static_cast<long long>(srows) != nv || scols != 3 ||
            !Eigen::Map<const Eigen::VectorXd>(sum.data(), Eigen::Index(sum.size())).allFinite())
          throw corrupt("HMC mass reference position sum of chain " + std::to_string(k) +
                        " is not " + std::to_string(nv) + " x 3 finite numbers");
        cp.chains[std::size_t(k)].mass_reference_sum =
            Eigen::Map<const Eigen::Matrix3Xd>(sum.data(), 3, nv);
      }
    }
    HmcOptions& m = u.sampler.hmc;
    m.step = h.read_attribute_double("hmc_step");
    m.trajectory_time = h.read_attribute_double("hmc_trajectory_time");
    m.jitter = h.read_attribute_double("hmc_jitter");
    m.target_acceptance = h.read_attribute_double("hmc_target_acceptance");
    m.adapt_gain = h.read_attribute_double("hmc_adapt_gain");
    m.max_steps = static_cast<int>(h.read_attribute_int("hmc_max_steps"));
    m.projected_mass = h.read_attribute_int("hmc_projected_mass") != 0;
    m.mass_shift_fraction = h.read_attribute_double("hmc_mass_shift_fraction");
    m.area_volume = HmcAreaVolume::penalty;  // a file without the attribute
    if (h.has_attribute("hmc_area_volume")) {
      try {
        m.area_volume = hmc_area_volume_from_string(h.read_attribute_string("hmc_area_volume"));
      } catch (const std::invalid_argument& e) {
        throw corrupt(e.what());
      }
    }
    if (h.has_attribute("hmc_mass_reference")) {
      try {
        m.mass_reference =
            hmc_mass_reference_from_string(h.read_attribute_string("hmc_mass_reference"));
      } catch (const std::invalid_argument& e) {
        throw corrupt(e.what());
      }
    }
    if (m.mass_reference == HmcMassReference::thermal) {
      std::vector<int> at_mean;
      if (h.has("/chain_mass_at_thermal_mean")) {
        const auto [rows, cols] = h.read("/chain_mass_at_thermal_mean", at_mean);
        if (static_cast<long long>(rows) != chain_count || cols != 1)
          throw corrupt("chain_mass_at_thermal_mean is not one flag per chain");
      } else {  // a file without the flags: every chain past the window counts as rebuilt
        for (const McChainState& c : cp.chains)
          at_mean.push_back(c.sweep >= u.sampler.adapt_sweeps ? 1 : 0);
      }
      for (long long k = 0; k < chain_count; ++k) {
        McChainState& c = cp.chains[std::size_t(k)];
        const int flag = at_mean[std::size_t(k)];
        if ((flag != 0 && flag != 1) || (flag == 1 && c.sweep < u.sampler.adapt_sweeps))
          throw corrupt("chain " + std::to_string(k) + "'s mass matrix flag (" +
                        std::to_string(flag) + ") is not 0, or 1 after the adaptive phase");
        c.mass_at_thermal_mean = flag == 1;
      }
    }
  }
  try {
    u.validate();
  } catch (const std::invalid_argument& e) {
    throw corrupt(e.what());
  }
  cp.chain = cp.chains[0];
  cp.series = cp.chain_series[0];
  return cp;
}

}  // namespace rbc
