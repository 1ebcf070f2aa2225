// Homogenisation (homogenise/): linear moduli in closed form and from the periodic cell
// problem, as `rbc moduli` computes them, and the density Psi with its stress, as `rbc psi`.
#include <Eigen/Dense>
#include <random>

#include "common.hpp"
#include "homogenise/disordered_network.hpp"
#include "homogenise/invariant_laws.hpp"
#include "homogenise/lattice_density.hpp"
#include "homogenise/moduli.hpp"
#include "homogenise/periodic_network.hpp"

namespace rbc::py_bind {

void bind_homogenise(py::module_& m) {
  m.def(
      "moduli",
      [](const py::object& wlc_o, const py::object& steric_o, const std::string& network, int cells,
         double disorder, int seeds, py::object cancel, py::object progress) {
        const PyWlc pw = wlc_or_default(wlc_o);
        const PySteric ps = steric_or_default(steric_o);
        const WlcParameters& wlc = pw.lib;
        const StericParameters& steric = ps.lib;
        if (network != "hex" && network != "disordered")
          throw py::value_error("network '" + network + "' is not one of hex, disordered");
        if (!(disorder >= 0.0 && disorder <= 1.0))
          throw py::value_error("disorder must lie in [0, 1], got " + num(disorder));
        if (cells < 0)
          throw py::value_error("cells must be positive, got " + std::to_string(cells));
        const NetworkMaterial mat = make_network_material(wlc, steric);
        const LinearModuli closed = closed_form_moduli(mat.w, steric);
        const LinearModuli explicit_forms = paper_explicit_moduli(wlc, steric);
        py::dict j;  // the keys of `rbc moduli --json` (without timing)
        j["units"] = "uN/m (= pN/um)";
        j["network"] = network;
        j["mu_closed"] = closed.mu_pN_per_um;
        j["K_closed"] = closed.K_pN_per_um;
        j["young_closed"] = closed.young_pN_per_um();
        j["poisson_closed"] = closed.poisson();
        j["mu_paper_formula"] = explicit_forms.mu_pN_per_um;
        j["K_paper_formula"] = explicit_forms.K_pN_per_um;
        j["steric_C"] = mat.C_pN_per_um;
        const auto cb = make_callbacks(std::move(cancel), std::move(progress));
        if (network == "hex") {
          const int n = cells > 0 ? cells : 4;
          if (n > 200) throw py::value_error("cells must be <= 200, got " + std::to_string(n));
          struct Hex {
            LinearModuli num;
            RelaxResult r;
            bool relaxed = false;
            double psi_lattice = 0, psi_patch = 0;
          };
          const Hex h = run_released(cb, [&] {
            const PeriodicNetwork net = make_hexagonal_patch(n, wlc.lbar_um);
            const HomogenisedState hs = homogenise_patch(net, mat, Eigen::Matrix2d::Identity());
            Hex out;
            out.num = moduli_from_tangent(hs.relaxed_tangent);
            out.relaxed = hs.relax.converged();
            // Theorem 3 check of the CLI: a generic F relaxed from a seeded non-affine start.
            Eigen::Matrix2d F;
            F << 1.3, 0.2, -0.1, 0.9;
            std::mt19937 rng(1);
            std::uniform_real_distribution<double> u(-0.1 * wlc.lbar_um, 0.1 * wlc.lbar_um);
            Eigen::Matrix2Xd U0(2, net.vertex_count());
            for (int i = 0; i < U0.size(); ++i) U0.data()[i] = u(rng);
            out.r = relax_patch(net, mat, F, U0);
            out.psi_lattice = lattice_density(mat.w, mat.C_pN_per_um, steric, F);
            out.psi_patch = out.r.energy_pNum / net.reference_area_um2();
            return out;
          });
          j["mu_numeric"] = h.num.mu_pN_per_um;
          j["K_numeric"] = h.num.K_pN_per_um;
          j["young"] = h.num.young_pN_per_um();
          j["poisson"] = h.num.poisson();
          j["cells"] = n;
          j["mu_relative_difference"] = h.num.mu_pN_per_um / closed.mu_pN_per_um - 1.0;
          j["K_relative_difference"] = h.num.K_pN_per_um / closed.K_pN_per_um - 1.0;
          j["max_internal_displacement_um"] = h.r.max_displacement_um;
          j["max_internal_displacement_over_lbar"] = h.r.max_displacement_um / wlc.lbar_um;
          j["relaxation_start_amplitude_over_lbar"] = 0.1;
          j["psi_patch_over_lattice_minus_1"] = h.psi_patch / h.psi_lattice - 1.0;
          j["newton_iterations"] = h.r.iterations;
          j["residual_pN"] = h.r.residual_pN;
          j["converged"] = h.r.converged() && h.relaxed;
          return j;
        }
        DisorderOptions d;
        d.cells = cells > 0 ? cells : 12;
        d.disorder = disorder;
        d.spacing_um = wlc.lbar_um;
        d.validate();
        if (seeds < 1) throw py::value_error("seeds must be >= 1, got " + std::to_string(seeds));
        const ProgressSink sink = make_progress_sink(cb);
        const std::vector<DisorderedSample> samples =
            run_released(cb, [&] { return disordered_study(d, mat, seeds, 1, {}, sink); });
        auto stat = [&](auto get) {
          std::vector<double> v;
          for (const auto& s : samples) v.push_back(get(s));
          return mean_std(v);
        };
        auto put = [&](const char* key, MeanStd ms, const char* std_key) {
          j[key] = ms.mean;
          j[std_key] = ms.std;
        };
        put("mu_numeric", stat([](const DisorderedSample& s) { return s.relaxed.mu_pN_per_um; }),
            "mu_numeric_std");
        put("K_numeric", stat([](const DisorderedSample& s) { return s.relaxed.K_pN_per_um; }),
            "K_numeric_std");
        put("young", stat([](const DisorderedSample& s) { return s.relaxed.young_pN_per_um(); }),
            "young_std");
        put("poisson", stat([](const DisorderedSample& s) { return s.relaxed.poisson(); }),
            "poisson_std");
        put("mu_affine", stat([](const DisorderedSample& s) { return s.affine.mu_pN_per_um; }),
            "mu_affine_std");
        put("K_affine", stat([](const DisorderedSample& s) { return s.affine.K_pN_per_um; }),
            "K_affine_std");
        put("degree6_fraction", stat([](const DisorderedSample& s) { return s.degree6_fraction; }),
            "degree6_fraction_std");
        put("prestress_uN_per_m",
            stat([](const DisorderedSample& s) { return s.prestress_pN_per_um; }), "prestress_std");
        j["phi_over_area"] = stat([](const DisorderedSample& s) { return s.phi_over_area; }).mean;
        j["disorder"] = d.disorder;
        j["cells"] = d.cells;
        j["rows"] = disordered_rows(d.cells);
        j["row_distortion"] = disordered_row_distortion(d.cells);
        j["vertices"] = samples.front().vertices;
        j["seeds"] = seeds;
        double worst = 0;
        bool converged = true;
        for (const auto& s : samples) {
          worst = std::max(worst, s.relax.residual_pN);
          converged = converged && s.relax.converged();
        }
        j["worst_residual_pN"] = worst;
        j["converged"] = converged;
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
