// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/mc_workflow.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "core/h5file.hpp"
#include "core/io.hpp"
#include "core/units.hpp"
#include "discrete/hmc_sampler.hpp"

namespace rbc {

SerialOpenMpScope::SerialOpenMpScope() : saved_(omp_get_max_threads()) {
  omp_set_num_threads(1);
}
SerialOpenMpScope::~SerialOpenMpScope() {
  omp_set_num_threads(saved_);
}

std::string to_string(McStart s) {
  return s == McStart::equilibrium ? "equilibrium" : "rest";
}

McStart mc_start_from_string(const std::string& s) {
  if (s == "equilibrium") return McStart::equilibrium;
  if (s == "rest") return McStart::rest;
  throw std::invalid_argument("start '" + s + "' is not one of equilibrium, rest");
}

McZeroTemperatureStart mc_zero_temperature_start(const Network& net, McRunSetup& setup,
                                                 const McStartOptions& options,
                                                 const ProgressSink& progress) {
  McZeroTemperatureStart out;
  Positions x = net.rest;
  ConstraintMultipliers lambda;
  StretchOptions so = options.stretch;
  if (!so.minimiser.cancel) so.minimiser.cancel = options.cancel;
  const std::vector<double> forces = mc_startup_forces(setup.force_pN);
  for (std::size_t k = 0; k < forces.size(); ++k) {
    throw_if_cancelled(options.cancel);
    if (forces.size() > 1)
      report(progress, "zero-temperature start-up: step " + std::to_string(k + 1) + "/" +
                           std::to_string(forces.size()) + " at " + std::to_string(forces[k]) +
                           " pN");
    out.equilibrium = solve_equilibrium(net, forces[k], x, lambda, so);
    if (!out.equilibrium.converged) return out;
  }
  report(progress,
         "zero-temperature equilibrium: D_A = " + std::to_string(out.equilibrium.axial_um) +
             " um, D_T = " + std::to_string(out.equilibrium.transverse_um) + " um");
  out.converged = true;
  setup.multipliers = lambda;
  setup.reference_axial_um = out.equilibrium.axial_um;
  setup.reference_transverse_um = out.equilibrium.transverse_um;
  out.start = options.start == McStart::rest ? net.rest : x;
  return out;
}

void check_mc_resume_network(const McCheckpointNetwork& network, const McResumeRequest& r,
                             const std::string& name) {
  if (r.bending_model && *r.bending_model != network.bending_model)
    throw std::invalid_argument("checkpoint '" + name + "' was run with " +
                                to_string(network.bending_model) + " bending, not " +
                                to_string(*r.bending_model));
}

std::string check_mc_resume(const McCheckpoint& cp, const McResumeRequest& r,
                            const std::string& name) {
  auto differs = [](double a, double b) { return std::abs(a - b) > 1e-12 * (1 + std::abs(b)); };
  const std::string ck = "checkpoint '" + name + "'";
  if (r.force_pN && differs(*r.force_pN, cp.setup.force_pN))
    throw std::invalid_argument(ck + " was run at " + std::to_string(cp.setup.force_pN) +
                                " pN, not " + std::to_string(*r.force_pN) + " pN");
  if (r.temperature_K && differs(*r.temperature_K, cp.setup.sampler.temperature_K))
    throw std::invalid_argument(ck + " was run at " +
                                std::to_string(cp.setup.sampler.temperature_K) + " K, not " +
                                std::to_string(*r.temperature_K) + " K");
  if (r.seed && *r.seed != cp.setup.sampler.seed)
    throw std::invalid_argument(ck + " was seeded with " + std::to_string(cp.setup.sampler.seed));
  if (r.penalty_scale && differs(*r.penalty_scale, cp.setup.penalty_scale))
    throw std::invalid_argument(ck + " was run with penalty scale " +
                                std::to_string(cp.setup.penalty_scale) + ", not " +
                                std::to_string(*r.penalty_scale));
  if (r.algorithm && *r.algorithm != cp.setup.sampler.algorithm)
    throw std::invalid_argument(ck + " was run with the " + to_string(cp.setup.sampler.algorithm) +
                                " sampler, not " + to_string(*r.algorithm));
  if (r.area_volume && *r.area_volume != cp.setup.sampler.hmc.area_volume)
    throw std::invalid_argument(ck + " was run with --hmc-area-volume " +
                                to_string(cp.setup.sampler.hmc.area_volume) + ", not " +
                                to_string(*r.area_volume));
  if (r.chains && *r.chains != cp.setup.sampler.chains)
    throw std::invalid_argument(ck + " holds " + std::to_string(cp.setup.sampler.chains) +
                                " chains, not --chains " + std::to_string(*r.chains));
  if (r.adapt_sweeps && *r.adapt_sweeps != cp.setup.sampler.adapt_sweeps)
    throw std::invalid_argument(ck + " adapts the step for " +
                                std::to_string(cp.setup.sampler.adapt_sweeps) +
                                " sweeps, not --adapt-sweeps " + std::to_string(*r.adapt_sweeps));
  // The adaptive phase is stored in absolute sweeps and kept: a resumed chain continues
  // exactly as the run that wrote the checkpoint would have. Extending a run whose phase was
  // a fraction of its length is the one case where a straight run of the new length differs.
  const McSchedule& schedule = cp.schedule;
  const long long a = cp.setup.sampler.adapt_sweeps;
  if (schedule.adapt_fraction < 0) return {};
  const double fraction = r.adapt_fraction ? *r.adapt_fraction : schedule.adapt_fraction;
  const long long straight = std::llround(fraction * double(r.total_sweeps));
  if (straight == a) return {};
  std::ostringstream m;
  m << "the checkpoint's adaptive phase is kept: sweeps 1-" << a << " (--adapt-fraction "
    << fraction << " of its " << schedule.planned_sweeps << " sweeps); a straight "
    << r.total_sweeps << "-sweep run adapts sweeps 1-" << straight
    << ", so this chain matches it up to sweep " << std::min(a, straight)
    << " only (statistics use the sweeps after " << a
    << "); run both with --adapt-sweeps N for identical chains";
  return m.str();
}

namespace {

nlohmann::json stat_json(const BlockingResult& b) {
  return {{"mean", b.mean},
          {"error", b.error},
          {"std", std::sqrt(b.variance)},
          {"inefficiency", b.inefficiency},
          {"blocking_converged", b.converged}};
}

nlohmann::json pooled_json(const BlockingResult& b, const McConvergence& c) {
  nlohmann::json j = stat_json(b);
  j.update({{"rhat", c.rhat},
            {"rhat_converged", c.converged},
            {"between_chain_error", c.between_chain_error},
            {"chain_chi2", c.chain_chi2},
            {"chain_p_value", c.chain_p_value}});
  return j;
}

nlohmann::json chain_json(const BlockingResult& b) {
  return {{"mean", b.mean},
          {"error", b.error},
          {"inefficiency", b.inefficiency},
          {"blocking_converged", b.converged}};
}

}  // namespace

nlohmann::json to_json(const McSummary& s, const McRunSetup& su) {
  nlohmann::json per_chain = nlohmann::json::array();
  for (const McChainSummary& c : s.per_chain)
    per_chain.push_back({{"seed", c.seed},
                         {"acceptance", c.acceptance},
                         {"energy_pNum", chain_json(c.energy)},
                         {"axial_um", chain_json(c.axial)},
                         {"transverse_um", chain_json(c.transverse)},
                         {"area_um2", chain_json(c.area)},
                         {"volume_um3", chain_json(c.volume)}});
  return {
      {"samples", s.samples},
      {"samples_per_chain", s.chains > 0 ? s.samples / std::size_t(s.chains) : 0},
      {"discarded_transient", s.discarded},
      {"acceptance", s.acceptance},
      {"chains", s.chains},
      {"energy_pNum", pooled_json(s.energy, s.energy_check)},
      {"axial_um", pooled_json(s.axial, s.axial_check)},
      {"transverse_um", pooled_json(s.transverse, s.transverse_check)},
      {"area_um2", pooled_json(s.area, s.area_check)},
      {"volume_um3", pooled_json(s.volume, s.volume_check)},
      {"rhat_method", "rank-normalised split-R-hat, max of bulk and tail (Vehtari et al. 2021)"},
      {"rhat_threshold", kMcRhatThreshold},
      {"converged", s.converged},
      {"thermal_shift_axial_um", s.axial.mean - su.reference_axial_um},
      {"thermal_shift_axial_error_um", s.axial.error},
      {"thermal_shift_transverse_um", s.transverse.mean - su.reference_transverse_um},
      {"thermal_shift_transverse_error_um", s.transverse.error},
      {"max_area_drift", s.max_area_drift},
      {"max_volume_drift", s.max_volume_drift},
      {"per_chain", per_chain}};
}

nlohmann::json to_json(const McThreadDecision& d) {
  return {{"used", d.threads}, {"requested", d.requested}, {"reason", d.reason}};
}

nlohmann::json mc_run_json(const Network& net, const McRun& run) {
  const McRunSetup& su = run.setup();
  nlohmann::json j = mc_run_keys(net, run);
  if (const auto* h = dynamic_cast<const HmcSampler*>(&run.sampler())) {
    const HmcMassInfo& m = h->mass_info();
    long long evaluations = 0, solves = 0, failed_solves = 0, failed_reverse = 0;
    for (int c = 0; c < run.chain_count(); ++c) {
      const auto& chain = dynamic_cast<const HmcSampler&>(run.chain(c));
      evaluations += chain.evaluations();
      solves += chain.solves();
      failed_solves += chain.failed_solves();
      failed_reverse += chain.failed_reverse_checks();
    }
    j["hmc"] = {{"trajectory_time", su.sampler.hmc.trajectory_time},
                {"evaluations", evaluations},
                {"solves", solves},
                {"mass_matrix", m.exact ? "exact Hessian" : "projected Hessian"},
                {"mass_shift_pN_per_um", m.shift_pN_per_um},
                {"mass_reference", to_string(su.sampler.hmc.mass_reference)},
                {"area_volume", to_string(su.sampler.hmc.area_volume)},
                {"constraint_failed_solves", failed_solves},
                {"constraint_failed_reverse_checks", failed_reverse},
                {"mass_built_at", m.thermal ? "thermal mean" : "start"},
                {"mass_reference_transitions", m.reference_transitions},
                {"rigid_mass_pN_per_um", m.rigid_mass_pN_per_um},
                {"factor_nonzeros", m.factor_nonzeros}};
  }
  return j;
}

nlohmann::json mc_run_keys(const Network& net, const McRun& run) {
  const McRunSetup& su = run.setup();
  nlohmann::json seeds = nlohmann::json::array(), sweeps = nlohmann::json::array(),
                 steps = nlohmann::json::array();
  double area_drift = 0, volume_drift = 0;
  for (int c = 0; c < run.chain_count(); ++c) {
    seeds.push_back(mc_chain_seed(su.sampler.seed, c));
    sweeps.push_back(run.chain(c).sweeps_done());
    steps.push_back(run.chain(c).step_um());
    area_drift = std::max(area_drift, run.chain(c).max_area_drift_um2());
    volume_drift = std::max(volume_drift, run.chain(c).max_volume_drift_um3());
  }
  return {{"vertices", net.topo.num_vertices},
          {"force_pN", su.force_pN},
          {"temperature_K", su.sampler.temperature_K},
          {"kT_pNum", units::thermal_energy_pNum(su.sampler.temperature_K)},
          {"sampler", to_string(su.sampler.algorithm)},
          {"seed", su.sampler.seed},
          {"chains", run.chain_count()},
          {"chain_seeds", seeds},
          {"streams", su.sampler.streams},
          {"threads", to_json(run.thread_decision())},
          {"bending", to_string(net.bending_model)},
          {"penalty_scale", su.penalty_scale},
          {"colours", run.sampler().colour_count()},
          {"sweeps", run.sweeps_done()},
          {"chain_sweeps", sweeps},
          {"adaptive_sweeps", su.sampler.adapt_sweeps},
          {"step_um", run.sampler().step_um()},
          {"chain_steps", steps},
          {"reference_axial_um", su.reference_axial_um},
          {"reference_transverse_um", su.reference_transverse_um},
          {"running_total_drift_area_um2", area_drift},
          {"running_total_drift_volume_um3", volume_drift}};
}

namespace {

/// DIR/NAME.csv and DIR/NAME.h5 of one chain's series.
void write_chain_series(const std::string& dir, const std::string& name, const McRun& run,
                        int chain, const OutputRecord& record) {
  const unsigned long seed = mc_chain_seed(run.setup().sampler.seed, chain);
  CsvTable t;
  t.comments = {"rbc mc time series: one row per recorded sweep of chain " + std::to_string(chain) +
                    " of " + std::to_string(run.chain_count()) + " (seed " + std::to_string(seed) +
                    ")",
                "force_pN " + std::to_string(run.setup().force_pN) + ", temperature_K " +
                    std::to_string(run.setup().sampler.temperature_K) + ", adaptive sweeps " +
                    std::to_string(run.setup().sampler.adapt_sweeps) +
                    " (rows with sweep <= that are equilibration)"};
  t.comments.insert(t.comments.end(), record.comment_lines.begin(), record.comment_lines.end());
  t.header = mc_sample_columns();
  std::vector<double> flat_rows;
  const std::vector<McSample>& series = run.series(chain);
  for (const McSample& s : series) {
    t.rows.push_back(to_row(s));
    flat_rows.insert(flat_rows.end(), t.rows.back().begin(), t.rows.back().end());
  }
  write_csv(dir + "/" + name + ".csv", t);
  const std::string path = dir + "/" + name + ".h5";
  TempFile tmp(path);
  {
    H5File h = H5File::create(tmp.path(), path);
    if (!flat_rows.empty())
      h.write("/series", flat_rows.data(), hsize_t(series.size()), kMcSampleColumns);
    std::string cols;
    for (const auto& c : mc_sample_columns()) cols += (cols.empty() ? "" : ",") + c;
    h.write_attribute("columns", cols);
    h.write_attribute("force_pN", run.setup().force_pN);
    h.write_attribute("temperature_K", run.setup().sampler.temperature_K);
    h.write_attribute("chain", static_cast<long long>(chain));
    h.write_attribute("chains", static_cast<long long>(run.chain_count()));
    h.write_attribute("seed", std::to_string(seed));
    for (const auto& [key, text] : record.attributes) h.write_attribute(key, text);
    h.close();
  }
  tmp.commit();
}

}  // namespace

void write_mc_series(const std::string& dir, const McRun& run, const OutputRecord& record) {
  for (int c = 0; c < run.chain_count(); ++c)
    write_chain_series(dir, c == 0 ? "mc_series" : "mc_series_chain" + std::to_string(c), run, c,
                       record);
}

void write_mc_snapshot(const std::string& dir, const Network& net, const McRun& run,
                       const OutputRecord& record) {
  const Positions& x = run.sampler().positions();
  std::ostringstream name;
  name << dir << "/mc_snapshot_" << std::setw(8) << std::setfill('0')
       << run.sampler().sweeps_done();
  // displacement_um is |x - X| as in the stretch shapes; displacement_x_um its x component
  // (the bead axis).
  const Positions u = x - net.rest;
  MeshSnapshot s{x,
                 net.topo.faces,
                 {{"displacement_um", u.colwise().norm().transpose()},
                  {"displacement_x_um", u.row(0).transpose()}},
                 {},
                 {{"force_pN", run.setup().force_pN},
                  {"temperature_K", run.setup().sampler.temperature_K},
                  {"sweep", double(run.sampler().sweeps_done())}},
                 record.attributes};
  write_mesh_snapshot(name.str(), s);
}

}  // namespace rbc
