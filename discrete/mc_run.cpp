// SPDX-License-Identifier: GPL-3.0-or-later
#include "discrete/mc_run.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/geometry.hpp"
#include "core/validation.hpp"
#include "discrete/hmc_sampler.hpp"
#include "discrete/stretch.hpp"

namespace rbc {

const std::vector<std::string>& mc_sample_columns() {
  static const std::vector<std::string> names = {"sweep",         "energy_pNum", "axial_um",
                                                 "transverse_um", "area_um2",    "volume_um3",
                                                 "acceptance",    "step_um"};
  return names;
}

std::vector<double> to_row(const McSample& s) {
  return {double(s.sweep), s.energy_pNum, s.axial_um,   s.transverse_um,
          s.area_um2,      s.volume_um3,  s.acceptance, s.step_um};
}

McSample sample_from_row(const double* r) {
  McSample s;
  s.sweep = static_cast<long long>(std::llround(r[0]));
  s.energy_pNum = r[1];
  s.axial_um = r[2];
  s.transverse_um = r[3];
  s.area_um2 = r[4];
  s.volume_um3 = r[5];
  s.acceptance = r[6];
  s.step_um = r[7];
  return s;
}

void McRunSetup::validate() const {
  sampler.validate();
  validate_discrete_force(force_pN);
  // 1e4 x the network's own stiffness already pins A and V to ~1e-6 at 300 K.
  require_finite_in_range("penalty scale", "", penalty_scale, 0.0, 1e4);
  require_integer_in_range("sample interval (sweeps)", sample_every, 1,
                           std::numeric_limits<int>::max());
}

std::vector<double> mc_startup_forces(double force_pN) {
  if (!(force_pN >= 0) || !std::isfinite(force_pN))
    throw std::invalid_argument("start-up force must be finite and >= 0 pN, got " +
                                std::to_string(force_pN) + " pN");
  constexpr double kLinearUpTo_pN = 200.0, kLinearStep_pN = 40.0, kRatio = 1.2;
  std::vector<double> f;
  const double linear_end = std::min(force_pN, kLinearUpTo_pN);
  const int linear = std::max(1, static_cast<int>(std::ceil(linear_end / kLinearStep_pN)));
  for (int k = 1; k <= linear; ++k) f.push_back(linear_end * k / linear);
  if (force_pN > kLinearUpTo_pN) {
    const int geometric =
        static_cast<int>(std::ceil(std::log(force_pN / kLinearUpTo_pN) / std::log(kRatio)));
    for (int k = 1; k <= geometric; ++k)
      f.push_back(kLinearUpTo_pN * std::pow(force_pN / kLinearUpTo_pN, double(k) / geometric));
    f.back() = force_pN;  // (up to 200 pN the last entry is F k/k exactly)
  }
  return f;
}

namespace {
LoadState load_of(const McRunSetup& s) {
  LoadState l;
  l.force_pN = s.force_pN;
  l.multipliers = s.multipliers;
  l.stiffness_scale = s.penalty_scale;
  return l;
}
}  // namespace

McRun::McRun(const Network& net, const McRunSetup& setup, const Positions& start)
    : net_(net), setup_(setup) {
  if (setup_.sampler.algorithm == McAlgorithm::hmc) setup_.sampler.streams = 1;  // one chain
  setup_.validate();
  if (setup_.sampler.algorithm == McAlgorithm::hmc)
    sampler_ = std::make_unique<HmcSampler>(net, load_of(setup_), start, setup_.sampler);
  else
    sampler_ = std::make_unique<McSampler>(net, load_of(setup_), start, setup_.sampler);
}

McRun::McRun(const Network& net, const McRunSetup& setup, const McChainState& state,
             std::vector<McSample> series)
    : net_(net), setup_(setup), series_(std::move(series)) {
  if (setup_.sampler.algorithm == McAlgorithm::hmc) setup_.sampler.streams = 1;
  setup_.validate();
  if (setup_.sampler.algorithm == McAlgorithm::hmc) {
    if (state.mass_reference.cols() != net.topo.num_vertices)
      throw std::invalid_argument("HMC chain state has no mass reference positions");
    sampler_ = std::make_unique<HmcSampler>(net, load_of(setup_), state.x, state.mass_reference,
                                            setup_.sampler);
  } else {
    sampler_ = std::make_unique<McSampler>(net, load_of(setup_), state.x, setup_.sampler);
  }
  sampler_->restore(state);
}

McSample McRun::measure(const McSweepStats& st, double step) const {
  McSample s;
  const Positions& x = sampler_->positions();
  s.sweep = sampler_->sweeps_done();
  // The sampler's fixed-order sums (not network_energy / total_area, whose parallel reductions
  // are not bit-reproducible), so a resumed run reproduces the series bit for bit.
  s.energy_pNum = sampler_->energy();
  const Diameters d = measure_diameters(x);
  s.axial_um = d.axial_um;
  s.transverse_um = d.transverse_um;
  s.area_um2 = sampler_->area_um2();
  s.volume_um3 = sampler_->volume_um3();
  s.acceptance = st.acceptance();
  s.step_um = step;
  return s;
}

bool McRun::advance(long long total_sweeps, const std::function<bool(const McRun&)>& after_sweep) {
  while (sampler_->sweeps_done() < total_sweeps) {
    // Between sweeps: a cancelled run stops at the last completed sweep (checkpointable).
    throw_if_cancelled(setup_.cancel);
    const double step = sampler_->step_um();
    const McSweepStats st = sampler_->sweep();
    if (sampler_->sweeps_done() % setup_.sample_every == 0) series_.push_back(measure(st, step));
    if (after_sweep && !after_sweep(*this)) return false;
  }
  return true;
}

McSummary McRun::summarise() const {
  std::vector<McSample> prod;
  for (const McSample& s : series_)
    if (s.sweep > setup_.sampler.adapt_sweeps) prod.push_back(s);
  if (prod.size() < 8)
    throw std::invalid_argument("too few production samples for statistics (" +
                                std::to_string(prod.size()) + " < 8): run more sweeps");
  McSummary m;
  m.samples = prod.size();
  std::vector<double> e;
  for (const McSample& s : prod) e.push_back(s.energy_pNum);
  m.discarded = detect_equilibration(e).start;
  auto column = [&](double McSample::*field) {
    std::vector<double> c;
    for (std::size_t i = m.discarded; i < prod.size(); ++i) c.push_back(prod[i].*field);
    return correlated_mean(c);
  };
  m.energy = column(&McSample::energy_pNum);
  m.axial = column(&McSample::axial_um);
  m.transverse = column(&McSample::transverse_um);
  m.area = column(&McSample::area_um2);
  m.volume = column(&McSample::volume_um3);
  double acc = 0;
  for (std::size_t i = m.discarded; i < prod.size(); ++i) {
    acc += prod[i].acceptance;
    m.max_area_drift =
        std::max(m.max_area_drift, std::abs(prod[i].area_um2 - net_.area0_um2) / net_.area0_um2);
    m.max_volume_drift = std::max(
        m.max_volume_drift, std::abs(prod[i].volume_um3 - net_.volume0_um3) / net_.volume0_um3);
  }
  m.acceptance = acc / double(prod.size() - m.discarded);
  return m;
}

}  // namespace rbc
