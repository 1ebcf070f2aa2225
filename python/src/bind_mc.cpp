// SPDX-License-Identifier: GPL-3.0-or-later
// Metropolis Monte Carlo of the network (discrete/mc_run.hpp), started as `rbc mc` starts it
// (discrete/mc_workflow.hpp mc_zero_temperature_start: the zero-temperature equilibrium at the
// force by the continuation mc_startup_forces(), on one OpenMP thread), its multipliers held
// fixed while sampling.
#include <omp.h>

#include <cmath>

#include "common.hpp"
#include "core/units.hpp"
#include "discrete/mc_run.hpp"
#include "discrete/mc_workflow.hpp"
#include "discrete/stretch.hpp"

namespace rbc::py_bind {

namespace {

/// The sampler object: prepared state (network, start, setup), the run created at the first
/// run() call (so the adaptive phase can default to 20 % of the first run's sweeps, as the CLI).
class MonteCarlo {
 public:
  MonteCarlo(std::shared_ptr<PyNetwork> net, double force_pN, double temperature_K,
             unsigned long seed, int streams, py::object adapt_sweeps, int sample_every,
             double penalty_scale, const std::string& start, double initial_step_um,
             double target_acceptance, double adapt_gain, const std::string& sampler, int chains,
             const py::object& hmc_area_volume)
      : net_(std::move(net)), adapt_sweeps_(std::move(adapt_sweeps)) {
    finite("force_pN", force_pN);
    finite("sampling_temperature_K", temperature_K);
    finite("penalty_scale", penalty_scale);
    finite("initial_step_um", initial_step_um);
    finite("target_acceptance", target_acceptance);
    finite("adapt_gain", adapt_gain);
    if (!(temperature_K >= 0))
      throw py::value_error("sampling_temperature_K must be >= 0 K, got " + num(temperature_K));
    McStartOptions so;
    so.start = mc_start_from_string(start);  // ValueError naming the choices
    if (!adapt_sweeps_.is_none() && adapt_sweeps_.cast<long long>() < 0)
      throw py::value_error("adapt_sweeps must be >= 0, got " +
                            std::to_string(adapt_sweeps_.cast<long long>()));
    setup_.force_pN = force_pN;
    setup_.sampler.temperature_K = temperature_K;
    setup_.sampler.seed = seed;
    setup_.sampler.streams = streams;
    setup_.sampler.chains = chains;
    setup_.sampler.initial_step_um = initial_step_um;
    setup_.sampler.target_acceptance = target_acceptance;
    setup_.sampler.adapt_gain = adapt_gain;
    setup_.sampler.algorithm = mc_algorithm_from_string(sampler);  // ValueError naming choices
    // An option of the HMC sampler only: refused with another (rather than ignored).
    if (!hmc_area_volume.is_none() && setup_.sampler.algorithm != McAlgorithm::hmc)
      throw py::value_error("hmc_area_volume applies to sampler='hmc', got sampler='" + sampler +
                            "'");
    if (!hmc_area_volume.is_none())  // ValueError naming the choices
      setup_.sampler.hmc.area_volume =
          hmc_area_volume_from_string(hmc_area_volume.cast<std::string>());
    setup_.sample_every = sample_every;
    setup_.penalty_scale = penalty_scale;
    validated("MonteCarlo(force_pN=" + num(force_pN) +
                  ", sampling_temperature_K=" + num(temperature_K) +
                  ", streams=" + std::to_string(streams) + ", chains=" + std::to_string(chains) +
                  ", sample_every=" + std::to_string(sample_every) +
                  ", penalty_scale=" + num(penalty_scale) + ")",
              [&] { setup_.validate(); });
    const Network& nw = *net_->net;
    McZeroTemperatureStart z;
    run_released(nullptr, [&] {
      SerialOpenMpScope serial;
      z = mc_zero_temperature_start(nw, setup_, so);
    });
    if (!z.converged)
      raise_convergence_error("zero-temperature equilibrium at " + num(z.equilibrium.force_pN) +
                                  " pN did not converge: " + to_string(z.equilibrium.status) +
                                  ", residual " + num(z.equilibrium.residual_pN) + " pN",
                              z.equilibrium.residual_pN, z.equilibrium.force_pN);
    start_ = std::move(z.start);
  }

  /// Runs `sweeps` more sweeps with the GIL released; Ctrl-C (or cancel() returning true)
  /// stops at the end of the current sweep with KeyboardInterrupt, the chain left at the last
  /// completed sweep.
  void run(long long sweeps, py::object cancel) {
    if (sweeps < 0) throw py::value_error("sweeps must be >= 0, got " + std::to_string(sweeps));
    if (busy_) throw std::runtime_error("this MonteCarlo is running in another thread");
    const auto cb = make_callbacks(std::move(cancel), py::none());
    const CancelCheck poll = make_cancel_check(cb);
    if (!run_) {
      McRunSetup s = setup_;
      s.sampler.adapt_sweeps = adapt_sweeps_.is_none()
                                   ? static_cast<int>(std::llround(0.2 * double(sweeps)))
                                   : adapt_sweeps_.cast<int>();
      validated("MonteCarlo", [&] { s.validate(); });
      run_ = std::make_unique<McRun>(*net_->net, s, start_);
    }
    busy_ = true;
    struct Clear {
      bool& b;
      ~Clear() { b = false; }
    } clear{busy_};
    const long long target = run_->sweeps_done() + sweeps;
    // One sweep of every chain (in parallel) between the polls of the cancel hook.
    const bool finished = run_released(
        cb, [&] { return run_->advance(target, [&](const McRun&) { return !poll(); }); });
    if (!finished) {
      if (cb->error) {
        py::error_already_set e = std::move(*cb->error);
        cb->error.reset();
        throw e;
      }
      PyErr_SetString(PyExc_KeyboardInterrupt, "cancelled by the caller");
      throw py::error_already_set();
    }
  }

  py::dict summary() const {
    const McRun& r = need_run();
    const McSummary s = r.summarise();  // ValueError (library) with too few samples
    // The keys of `rbc mc --json` without the timing and thread fields.
    nlohmann::json j = mc_run_json(*net_->net, r);
    j.update(to_json(s, r.setup()));
    return py::module_::import("json").attr("loads")(j.dump());
  }

  py::dict series(int chain) const {
    py::dict d;
    const auto& cols = mc_sample_columns();
    const std::vector<McSample> empty;
    if (chain < 0 || chain >= setup_.sampler.chains)
      throw py::value_error("chain must be in [0, " + std::to_string(setup_.sampler.chains) +
                            "), got " + std::to_string(chain));
    const auto& rows = run_ ? run_->series(chain) : empty;
    for (std::size_t c = 0; c < cols.size(); ++c) {
      py::array_t<double> a(static_cast<py::ssize_t>(rows.size()));
      auto v = a.mutable_unchecked<1>();
      for (std::size_t i = 0; i < rows.size(); ++i) v(i) = to_row(rows[i])[c];
      d[py::str(cols[c])] = a;
    }
    return d;
  }

  py::array positions() const {
    Positions x = run_ ? run_->sampler().positions() : start_;
    return owning_rows(std::move(x));  // a copy: the chain keeps moving
  }
  long long sweeps_done() const { return run_ ? run_->sweeps_done() : 0; }
  double energy() const { return need_run().sampler().energy(); }
  double step() const { return need_run().sampler().step_um(); }
  const McRunSetup& setup() const { return setup_; }
  const std::shared_ptr<PyNetwork>& network() const { return net_; }

 private:
  const McRun& need_run() const {
    if (!run_) throw py::value_error("no sweeps run yet: call run(sweeps) first");
    return *run_;
  }
  std::shared_ptr<PyNetwork> net_;
  py::object adapt_sweeps_;
  McRunSetup setup_;
  Positions start_;
  std::unique_ptr<McRun> run_;
  bool busy_ = false;
};

}  // namespace

void bind_mc(py::module_& m) {
  py::class_<MonteCarlo>(
      m, "MonteCarlo",
      "Monte Carlo of a Network at sampling_temperature_K (sampler='metropolis': single-vertex "
      "moves, a sweep offers every vertex one; 'hmc': Hamiltonian Monte Carlo of all vertices, a "
      "sweep is one trajectory) (the WLC keeps its own "
      "wlc_temperature_K), started at the zero-temperature equilibrium at force_pN with its "
      "area/volume multipliers held fixed, penalty stiffnesses scaled by penalty_scale (as "
      "`rbc mc`). adapt_sweeps=None: the first 20 % of the first run() adapt the step. chains "
      "independent chains (seeded from (seed, chain), run one per OpenMP thread, results "
      "independent of the threads) are pooled: summary() gives their pooled means and errors, "
      "R-hat per quantity and per-chain statistics; positions, energy and step are chain 0's. "
      "hmc_area_volume (sampler='hmc' only): how HMC holds the area and volume, 'exact' "
      "(constraints, the default when None) or 'penalty' (the Metropolis sampler's penalties), as "
      "`rbc mc --hmc-area-volume`.")
      .def(py::init<std::shared_ptr<PyNetwork>, double, double, unsigned long, int, py::object, int,
                    double, const std::string&, double, double, double, const std::string&, int,
                    const py::object&>(),
           py::arg("network"), py::kw_only(), py::arg("force_pN") = 0.0,
           py::arg("sampling_temperature_K") = 300.0, py::arg("seed") = 1, py::arg("streams") = 1,
           py::arg("adapt_sweeps") = py::none(), py::arg("sample_every") = 1,
           py::arg("penalty_scale") = McRunSetup{}.penalty_scale, py::arg("start") = "equilibrium",
           py::arg("initial_step_um") = 0.0, py::arg("target_acceptance") = 0.4,
           py::arg("adapt_gain") = 0.5, py::arg("sampler") = "metropolis",
           py::arg("chains") = McOptions{}.chains, py::arg("hmc_area_volume") = py::none())
      .def("run", &MonteCarlo::run, py::arg("sweeps"), py::arg("cancel") = py::none(),
           "Run `sweeps` more sweeps (GIL released; Ctrl-C raises KeyboardInterrupt at the end of "
           "the current sweep and leaves the chain there).")
      .def("summary", &MonteCarlo::summary,
           "Means and blocking errors of the production samples: a dict with the keys of "
           "`rbc mc --json`; each quantity's statistics (mean, error, std, inefficiency) are "
           "in its key's unit (energy_pNum, axial_um, ...); acceptance and drifts are "
           "dimensionless")
      .def_property_readonly(
          "series", [](const MonteCarlo& mc) { return mc.series(0); },
          "time series of chain 0: dict of arrays (sweep, energy_pNum, axial_um, "
          "transverse_um, area_um2, volume_um3, acceptance, step_um)")
      .def("chain_series", &MonteCarlo::series, py::arg("chain"),
           "time series of chain `chain` (0-based), as `series`")
      .def_property_readonly("positions", &MonteCarlo::positions,
                             "(N, 3) current positions in um (copy)")
      .def_property_readonly("sweeps_done", &MonteCarlo::sweeps_done, "sweeps run so far")
      .def_property_readonly("energy_pNum", &MonteCarlo::energy,
                             "free energy of the current state (pN um)")
      .def_property_readonly("step_um", &MonteCarlo::step, "current trial step (um)")
      .def_property_readonly("network", &MonteCarlo::network, "the sampled rbc.Network")
      .def_property_readonly(
          "multipliers", [](const MonteCarlo& mc) { return mc.setup().multipliers; },
          "the area/volume multipliers held fixed (pN/um, pN/um^2)")
      .def_property_readonly(
          "reference_axial_um", [](const MonteCarlo& mc) { return mc.setup().reference_axial_um; },
          "D_A of the zero-temperature start (um)")
      .def_property_readonly(
          "reference_transverse_um",
          [](const MonteCarlo& mc) { return mc.setup().reference_transverse_um; },
          "D_T of the zero-temperature start (um)")
      .def_property_readonly(
          "kT_pNum",
          [](const MonteCarlo& mc) {
            return units::thermal_energy_pNum(mc.setup().sampler.temperature_K);
          },
          "k_B T at the sampling temperature (pN um)");
}

}  // namespace rbc::py_bind
