// SPDX-License-Identifier: GPL-3.0-or-later
// Homogenisation (homogenise/): linear moduli in closed form and from the periodic cell
// problem, as `rbc moduli` computes them, and the density Psi with its stress, as `rbc psi`.
#include <Eigen/Dense>
#include <random>

#include "common.hpp"
#include "homogenise/disordered_network.hpp"
#include "homogenise/invariant_laws.hpp"
#include "homogenise/lattice_density.hpp"
#include "homogenise/moduli.hpp"
#include "homogenise/moduli_study.hpp"
#include "homogenise/periodic_network.hpp"
#include "homogenise/thermal_moduli.hpp"

namespace rbc::py_bind {

void bind_homogenise(py::module_& m) {
  m.def(
      "moduli",
      [](const py::object& wlc_o, const py::object& steric_o, const std::string& network, int cells,
         double disorder, int seeds, py::object cancel, py::object progress) {
        const PyWlc pw = wlc_or_default(wlc_o);
        const PySteric ps = steric_or_default(steric_o);
        ModuliStudyOptions so;
        so.network = moduli_network_from_string(network);  // ValueError naming the choices
        so.cells = cells;
        so.disorder = finite("disorder", disorder);
        so.seeds = seeds;
        validated("moduli(network='" + network + "', cells=" + std::to_string(cells) +
                      ", disorder=" + num(disorder) + ", seeds=" + std::to_string(seeds) + ")",
                  [&] { so.validate(); });
        const auto cb = make_callbacks(std::move(cancel), std::move(progress));
        const ProgressSink sink = make_progress_sink(cb);
        // The keys of `rbc moduli --json` without the timing fields.
        const ModuliStudy study =
            run_released(cb, [&] { return run_moduli_study(pw.lib, ps.lib, so, sink); });
        py::dict j = py::module_::import("json").attr("loads")(study.json.dump());
        return j;
      },
      py::kw_only(), py::arg("wlc") = py::none(), py::arg("steric") = py::none(),
      py::arg("network") = "hex", py::arg("cells") = 0, py::arg("disorder") = 0.5,
      py::arg("seeds") = 4, py::arg("cancel") = py::none(), py::arg("progress") = py::none(),
      "Linear moduli (uN/m = pN/um) as `rbc moduli --json` reports them: closed forms (Sec. 4.3), "
      "the paper's explicit formulas, and the numerical cell problem on a periodic hexagonal patch "
      "(network='hex', cells default 4) or disordered networks (network='disordered', cells "
      "default 12, `seeds` seeds, disorder X in [0, 1]). Returns a dict.");

  m.def(
      "thermal_moduli",
      [](double sampling_temperature, const py::object& wlc_o, const py::object& steric_o,
         const std::string& network, int cells, double disorder, long long sweeps,
         long long warmup_sweeps, double strain, int batches, unsigned long seed, py::object cancel,
         py::object progress) {
        const PyWlc pw = wlc_or_default(wlc_o);
        const PySteric ps = steric_or_default(steric_o);
        ThermalStudyOptions so;
        so.network = moduli_network_from_string(network);  // ValueError naming the choices
        so.cells = cells;
        so.disorder = finite("disorder", disorder);
        so.sampling.temperature_K = finite("sampling_temperature", sampling_temperature);
        so.sampling.sweeps = sweeps;
        so.sampling.warmup_sweeps = warmup_sweeps;
        so.sampling.strain = finite("strain", strain);
        so.sampling.batches = batches;
        so.sampling.seed = seed;
        validated("thermal_moduli(sampling_temperature=" + num(sampling_temperature) +
                      ", network='" + network + "', cells=" + std::to_string(cells) +
                      ", sweeps=" + std::to_string(sweeps) + ", strain=" + num(strain) + ")",
                  [&] { so.validate(); });
        const auto cb = make_callbacks(std::move(cancel), std::move(progress));
        so.sampling.cancel = make_cancel_check(cb);
        const ProgressSink sink = make_progress_sink(cb);
        const nlohmann::json j =
            run_released(cb, [&] { return thermal_moduli_study(pw.lib, ps.lib, so, sink); });
        so.sampling.cancel = {};  // holds the callbacks' state, which must be released with the GIL
        py::dict d = py::module_::import("json").attr("loads")(j.dump());
        return d;
      },
      py::kw_only(), py::arg("sampling_temperature"), py::arg("wlc") = py::none(),
      py::arg("steric") = py::none(), py::arg("network") = "hex", py::arg("cells") = 0,
      py::arg("disorder") = 0.5, py::arg("sweeps") = 20000, py::arg("warmup_sweeps") = 2000,
      py::arg("strain") = 0.005, py::arg("batches") = 20, py::arg("seed") = 1,
      py::arg("cancel") = py::none(), py::arg("progress") = py::none(),
      "Isothermal moduli (uN/m = pN/um) of the periodic cell sampled at `sampling_temperature` "
      "(K) against the zero-temperature Gamma limit, as `rbc moduli --sampling-temperature T "
      "--json` reports them (the same keys without the run record and wall_s): hexagonal patch "
      "(cells default 10) or the disordered network of seed 1 (cells default 12). Returns a "
      "dict.");

  m.def(
      "psi",
      [](const py::object& order, const py::handle& deformation, const py::object& wlc_o,
         const py::object& steric_o) {
        const PyWlc pw = wlc_or_default(wlc_o);
        const PySteric ps = steric_or_default(steric_o);
        const WlcExpansion e = order_arg(order);
        const auto a =
            py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(deformation);
        if (!a || a.ndim() < 2 || a.shape(a.ndim() - 1) != 2 || a.shape(a.ndim() - 2) != 2)
          throw py::value_error("deformation must have shape (2, 2) or (M, 2, 2)");
        require_finite("deformation", a.data(), static_cast<std::size_t>(a.size()));
        const py::ssize_t count = a.size() / 4;
        const IsotropicMembraneLaw law = make_membrane_law(pw.lib, ps.lib, e);
        const WlcDensity w = make_wlc_density(pw.lib, e);
        const double C = steric_constant(w, ps.lib);
        std::vector<Eigen::Matrix2d> Fs(count);
        for (py::ssize_t k = 0; k < count; ++k) {
          const double* f = a.data() + 4 * k;
          Fs[k] << f[0], f[1], f[2], f[3];
          if (!(Fs[k].determinant() > 0))
            throw py::value_error("deformation[" + std::to_string(k) +
                                  "] must have det F > 0, got det F = " + num(Fs[k].determinant()));
        }
        py::array_t<double> psi(count), i1(count), i2(count), lattice(count), d1(count), d2(count);
        py::array_t<double> P({count, py::ssize_t(2), py::ssize_t(2)});
        auto ps_ = psi.mutable_unchecked<1>();
        auto i1_ = i1.mutable_unchecked<1>();
        auto i2_ = i2.mutable_unchecked<1>();
        auto la_ = lattice.mutable_unchecked<1>();
        auto d1_ = d1.mutable_unchecked<1>();
        auto d2_ = d2.mutable_unchecked<1>();
        auto P_ = P.mutable_unchecked<3>();
        for (py::ssize_t k = 0; k < count; ++k) {
          const Invariants I = invariants(Fs[k]);
          const InvariantDerivatives d = law.evaluate(I.i1, I.i2);
          const Eigen::Matrix2d Pk = first_piola(Fs[k], d);
          ps_(k) = d.psi;
          i1_(k) = I.i1;
          i2_(k) = I.i2;
          d1_(k) = d.d1;
          d2_(k) = d.d2;
          la_(k) = lattice_density(w, C, ps.lib, Fs[k]);
          for (int r = 0; r < 2; ++r)
            for (int c = 0; c < 2; ++c) P_(k, r, c) = Pk(r, c);
        }
        const bool single = a.ndim() == 2;
        py::dict out;
        auto put = [&](const char* key, py::array v) {
          out[key] = single ? py::object(v.attr("__getitem__")(0)) : py::object(v);
        };
        put("psi_pN_per_um", psi);
        put("I1", i1);
        put("I2", i2);
        put("dpsi_dI1_pN_per_um", d1);
        put("dpsi_dI2_pN_per_um", d2);
        put("first_piola_pN_per_um", P);
        put("psi_lattice_pN_per_um", lattice);
        out["law"] = law.name;
        return out;
      },
      py::arg("order"), py::arg("deformation"), py::kw_only(), py::arg("wlc") = py::none(),
      py::arg("steric") = py::none(),
      "Homogenised density Psi (pN/um) of the given order (2, 3, 4 or 'full') at a 2x2 surface "
      "deformation gradient F (or a stack (M, 2, 2)), as `rbc psi --deformation`: Psi, I1 = J - 1, "
      "I2 = tr(F^T F) - 2, dPsi/dI1, dPsi/dI2, the first Piola stress P = dPsi/dF, and the "
      "un-averaged lattice density at phi = 0. Psi is inf outside the law's domain.");
}

}  // namespace rbc::py_bind
