// SPDX-License-Identifier: GPL-3.0-or-later
// Enums, parameter objects (natural units at the Python edge, the library's validate()) and the
// shared helpers declared in common.hpp.
#include <cmath>
#include <sstream>

#include "common.hpp"
#include "core/units.hpp"
#include "core/validation.hpp"

namespace rbc::py_bind {

std::string num(double v) {
  return py::repr(py::float_(v)).cast<std::string>();
}

double finite(const std::string& what, double value) {
  if (!std::isfinite(value))
    throw py::value_error(what + " = " + num(value) + " is not allowed: expected a finite number");
  return value;
}

void require_finite(const std::string& what, const double* data, std::size_t n) {
  for (std::size_t k = 0; k < n; ++k)
    if (!std::isfinite(data[k]))
      throw py::value_error(what + ": entry " + std::to_string(k) + " of " + std::to_string(n) +
                            " is " + num(data[k]) + "; expected finite values");
}

Positions positions_from_array(const py::handle& array, int expected_n, const char* what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array);
  if (!a) throw py::type_error(std::string(what) + " must be a float array of shape (N, 3)");
  auto shape_text = [&] {
    std::string s = "(";
    for (py::ssize_t k = 0; k < a.ndim(); ++k) s += (k ? ", " : "") + std::to_string(a.shape(k));
    return s + (a.ndim() == 1 ? ",)" : ")");
  };
  py::ssize_t n = -1;
  if (a.ndim() == 2 && a.shape(1) == 3) n = a.shape(0);
  if (a.ndim() == 1 && a.shape(0) % 3 == 0) n = a.shape(0) / 3;
  if (n < 0 || (expected_n >= 0 && n != expected_n)) {
    const std::string expected = expected_n >= 0 ? "(" + std::to_string(expected_n) + ", 3) or (" +
                                                       std::to_string(3 * expected_n) + ",)"
                                                 : "(N, 3)";
    throw py::value_error(std::string(what) + " must have shape " + expected + ", got " +
                          shape_text());
  }
  require_finite(what, a.data(), static_cast<std::size_t>(3 * n));
  Positions x(3, n);
  std::copy(a.data(), a.data() + 3 * n, x.data());
  return x;
}

WlcExpansion order_arg(const py::handle& h) {
  if (py::isinstance<py::int_>(h) && !py::isinstance<py::bool_>(h))
    return wlc_expansion_from_string(std::to_string(h.cast<long>()));
  return enum_arg<WlcExpansion>(h, wlc_expansion_from_string);
}

// ---- callbacks --------------------------------------------------------------------------------

std::shared_ptr<CallbackState> make_callbacks(py::object cancel, py::object progress) {
  if (!cancel.is_none() && !PyCallable_Check(cancel.ptr()))
    throw py::type_error("cancel must be None or a callable returning a bool");
  if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
    throw py::type_error("progress must be None or a callable taking a str");
  auto s = std::make_shared<CallbackState>();
  s->cancel = std::move(cancel);
  s->progress = std::move(progress);
  return s;
}

CancelCheck make_cancel_check(const std::shared_ptr<CallbackState>& s) {
  return [s]() -> bool {
    ++s->polls;
    py::gil_scoped_acquire gil;
    if (s->error) return true;  // a progress callback raised
    if (PyErr_CheckSignals() != 0) {
      s->error.emplace();  // fetches (and clears) KeyboardInterrupt or the handler's exception
      return true;
    }
    if (!s->cancel.is_none()) {
      try {
        return py::bool_(s->cancel());
      } catch (py::error_already_set& e) {
        s->error.emplace(std::move(e));
        return true;
      }
    }
    return false;
  };
}

ProgressSink make_progress_sink(const std::shared_ptr<CallbackState>& s) {
  if (s->progress.is_none()) return {};
  return [s](const std::string& message) {
    py::gil_scoped_acquire gil;
    if (s->error) return;
    try {
      s->progress(message);
    } catch (py::error_already_set& e) {
      s->error.emplace(std::move(e));  // raised at the next cancel poll
    }
  };
}

void raise_convergence_error(const std::string& message, double residual_pN, double force_pN) {
  const py::object cls = py::module_::import("rbc._rbc").attr("ConvergenceError");
  py::object e = cls(message);
  e.attr("residual_pN") = residual_pN;
  e.attr("force_pN") = force_pN;
  PyErr_SetObject(cls.ptr(), e.ptr());
  throw py::error_already_set();
}

std::vector<double> forces_arg(const py::handle& forces) {
  std::vector<double> out;
  if (py::isinstance<py::str>(forces))
    throw py::type_error("forces_pN must be a sequence of numbers");
  for (const py::handle item : py::iter(forces)) {
    const double f = finite("forces_pN[" + std::to_string(out.size()) + "]", item.cast<double>());
    if (f < 0)
      throw py::value_error("forces_pN[" + std::to_string(out.size()) + "] = " + num(f) +
                            " is not allowed: expected finite forces >= 0 pN");
    out.push_back(f);
  }
  if (out.empty()) throw py::value_error("forces_pN is empty (expected e.g. [0, 16, 88] pN)");
  return out;
}

// ---- parameter objects ------------------------------------------------------------------------

std::string PyWlc::repr() const {
  return "WlcParameters(persistence_nm=" + num(persistence_nm) + ", lmax_nm=" + num(lmax_nm) +
         ", lbar_nm=" + num(lbar_nm) + ", wlc_temperature_K=" + num(temperature_K) + ")";
}
std::string PyBending::repr() const {
  return "BendingParameters(kappa_J=" + num(kappa_J) + ", h0_per_um=" + num(h0_per_um) +
         ", model='" + to_string(model) + "', dihedral_mapping='" +
         (mapping == DihedralMapping::sphere_matched ? "sphere" : "li") + "')";
}
std::string PySteric::repr() const {
  return "StericParameters(q=" + num(q) + ", eta=" + num(eta) + ")";
}
std::string PyContact::repr() const {
  return "ContactParameters(fraction=" + num(fraction) + ", rule='" + to_string(rule) + "'" +
         (level_patch ? ", level_patch=True" : "") + ")";
}
std::string PyConstraints::repr() const {
  return "ConstraintParameters(area_stiffness_pN_per_um3=" + num(lib.area_stiffness_pN_per_um3) +
         ", volume_stiffness_pN_per_um5=" + num(lib.volume_stiffness_pN_per_um5) +
         ", tolerance=" + num(lib.tolerance) + ")";
}

PyWlc make_wlc(double persistence_nm, double lmax_nm, double lbar_nm, double temperature_K,
               const std::string& call) {
  PyWlc p{persistence_nm, lmax_nm, lbar_nm, temperature_K, {}};
  const std::string c = call.empty() ? p.repr() : call;
  finite(c + ": persistence_nm", persistence_nm);
  finite(c + ": lmax_nm", lmax_nm);
  finite(c + ": lbar_nm", lbar_nm);
  finite(c + (call.empty() ? ": wlc_temperature_K" : ": temperature_K"), temperature_K);
  p.lib.persistence_um = units::nm_to_um(persistence_nm);
  p.lib.lmax_um = units::nm_to_um(lmax_nm);
  p.lib.lbar_um = units::nm_to_um(lbar_nm);
  p.lib.temperature_K = temperature_K;
  validated(c, [&] { p.lib.validate(); });
  return p;
}

PyBending make_bending(double kappa_J, double h0_per_um, BendingModel model,
                       DihedralMapping mapping, const std::string& call) {
  PyBending p{kappa_J, h0_per_um, model, mapping, {}};
  const std::string c = call.empty() ? p.repr() : call;
  finite(c + ": kappa_J", kappa_J);
  finite(c + ": h0_per_um", h0_per_um);
  p.lib.kappa_pNum = units::joule_to_pNum(kappa_J);
  p.lib.h0_per_um = h0_per_um;
  validated(c, [&] { p.lib.validate(); });
  return p;
}

PySteric make_steric(double q, double eta, const std::string& call) {
  PySteric p{q, eta, {q, eta}};
  const std::string c = call.empty() ? p.repr() : call;
  finite(c + ": q", q);
  finite(c + ": eta", eta);
  validated(c, [&] { p.lib.validate(); });
  return p;
}

PyContact make_contact(double fraction, PatchRule rule, bool level_patch, const std::string& call) {
  PyContact p{fraction, rule, level_patch, {}};
  const std::string c = call.empty() ? p.repr() : call;
  finite(c + (call.empty() ? ": fraction" : ": contact_fraction"), fraction);
  p.lib.contact_fraction = fraction;
  p.lib.rule = rule;
  p.lib.keep_equal_x_together = level_patch;
  validated(c, [&] { p.lib.validate(); });
  return p;
}

PyConstraints make_constraints(double area_stiffness, double volume_stiffness, double tolerance) {
  PyConstraints p;
  p.lib.area_stiffness_pN_per_um3 = area_stiffness;
  p.lib.volume_stiffness_pN_per_um5 = volume_stiffness;
  p.lib.tolerance = tolerance;
  finite(p.repr() + ": area_stiffness_pN_per_um3", area_stiffness);
  finite(p.repr() + ": volume_stiffness_pN_per_um5", volume_stiffness);
  finite(p.repr() + ": tolerance", tolerance);
  validated(p.repr(), [&] { p.lib.validate(); });
  return p;
}

NetworkParameters PyNetwork::params() const {
  NetworkParameters p;
  p.wlc = wlc.lib;
  p.expansion = expansion;
  p.steric = steric.lib;
  p.bending = bending.lib;
  p.bending_model = bending.model;
  p.dihedral_mapping = bending.mapping;
  p.constraints = constraints.lib;
  p.tweezers = contact.lib;
  return p;
}

template <class T>
T cast_or(const py::object& o, T fallback, const char* what) {
  if (o.is_none()) return fallback;
  try {
    return o.cast<T>();
  } catch (const py::cast_error&) {
    throw py::type_error(std::string(what) + " must be an rbc." + what + " or None, got " +
                         py::repr(o).cast<std::string>());
  }
}
PyWlc wlc_or_default(const py::object& o) {
  return cast_or(o,
                 make_wlc(defaults::kPersistence_nm, defaults::kLmax_nm, defaults::kLbar_nm,
                          defaults::kWlcTemperature_K),
                 "WlcParameters");
}
PyBending bending_or_default(const py::object& o) {
  return cast_or(o,
                 make_bending(defaults::kKappa_J, 0.0, BendingModel::juelicher,
                              DihedralMapping::sphere_matched),
                 "BendingParameters");
}
PySteric steric_or_default(const py::object& o) {
  return cast_or(o, make_steric(1.0, 0.005), "StericParameters");
}
PyContact contact_or_default(const py::object& o) {
  return cast_or(o, make_contact(0.05, PatchRule::by_area), "ContactParameters");
}
PyConstraints constraints_or_default(const py::object& o) {
  return cast_or(o, make_constraints(100.0, 100.0, 1e-6), "ConstraintParameters");
}

namespace {
DihedralMapping dihedral_mapping_from_string(const std::string& s) {
  if (s == "sphere") return DihedralMapping::sphere_matched;
  if (s == "li") return DihedralMapping::li_et_al;
  throw std::invalid_argument("dihedral mapping '" + s + "' is not one of sphere, li");
}
}  // namespace

namespace {
/// "ModelParameters(name=value, ...)" of the given fields, for error messages.
std::string model_call(std::initializer_list<std::pair<const char*, double>> fields) {
  std::string s = "ModelParameters(";
  for (const auto& [name, value] : fields)
    s += (s.back() == '(' ? "" : ", ") + std::string(name) + "=" + num(value);
  return s + ")";
}
}  // namespace

void bind_parameters(py::module_& m) {
  py::enum_<BendingModel>(m, "BendingModel",
                          "Bending discretisation (strings: juelicher, dihedral)")
      .value("juelicher", BendingModel::juelicher, "Juelicher edge-based (converges to Helfrich)")
      .value("dihedral", BendingModel::dihedral, "Kantor-Nelson dihedral");
  py::enum_<DihedralMapping>(m, "DihedralMapping", "k_b(kappa) of the dihedral model (sphere, li)")
      .value("sphere_matched", DihedralMapping::sphere_matched, "k_b = 2 sqrt3 kappa")
      .value("li_et_al", DihedralMapping::li_et_al, "k_b = 2 kappa / sqrt3 (Li et al. 2005)");
  py::enum_<PatchRule>(m, "PatchRule", "Bead contact rule (strings: area, vertices)")
      .value("by_area", PatchRule::by_area, "fraction of the surface area, shares by vertex area")
      .value("by_vertex_count", PatchRule::by_vertex_count, "fraction of vertices, equal shares");
  py::enum_<WlcExpansion>(m, "Order", "Form of V: the full WLC or its Taylor order (2, 3, 4, full)")
      .value("full", WlcExpansion::full)
      .value("order2", WlcExpansion::order2)
      .value("order3", WlcExpansion::order3)
      .value("order4", WlcExpansion::order4);
  py::enum_<RestMeshQuality>(m, "MeshQuality",
                             "Rest triangulation (phi-minimised, projected, equal-area)")
      .value("phi_minimised", RestMeshQuality::phi_minimised)
      .value("projected", RestMeshQuality::projected)
      .value("equal_area", RestMeshQuality::equal_area);

  py::class_<PyWlc>(
      m, "WlcParameters",
      "Spectrin worm-like-chain parameters in natural units (Li et al. 2005, paper "
      "Table 1). wlc_temperature_K is the temperature of the WLC law, distinct from a "
      "Monte Carlo sampling_temperature_K.")
      .def(py::init([](double p, double lmax, double lbar, double t) {
             return make_wlc(p, lmax, lbar, t);
           }),
           py::kw_only(), py::arg("persistence_nm") = defaults::kPersistence_nm,
           py::arg("lmax_nm") = defaults::kLmax_nm, py::arg("lbar_nm") = defaults::kLbar_nm,
           py::arg("wlc_temperature_K") = defaults::kWlcTemperature_K)
      .def_readonly("persistence_nm", &PyWlc::persistence_nm)
      .def_readonly("lmax_nm", &PyWlc::lmax_nm)
      .def_readonly("lbar_nm", &PyWlc::lbar_nm)
      .def_readonly("wlc_temperature_K", &PyWlc::temperature_K)
      .def("__repr__", &PyWlc::repr)
      .def(py::pickle(
          [](const PyWlc& p) {
            return py::make_tuple(p.persistence_nm, p.lmax_nm, p.lbar_nm, p.temperature_K);
          },
          [](const py::tuple& t) {
            return make_wlc(t[0].cast<double>(), t[1].cast<double>(), t[2].cast<double>(),
                            t[3].cast<double>());
          }));

  py::class_<PyBending>(m, "BendingParameters",
                        "Bilayer bending: kappa in J (2e-19 J = 0.2 pN um), spontaneous curvature "
                        "H0 in 1/um, discretisation and dihedral k_b mapping.")
      .def(py::init([](double kappa, double h0, const py::object& model, const py::object& map) {
             return make_bending(kappa, h0,
                                 enum_arg<BendingModel>(model, bending_model_from_string),
                                 enum_arg<DihedralMapping>(map, dihedral_mapping_from_string));
           }),
           py::kw_only(), py::arg("kappa_J") = defaults::kKappa_J, py::arg("h0_per_um") = 0.0,
           py::arg("model") = "juelicher", py::arg("dihedral_mapping") = "sphere")
      .def_readonly("kappa_J", &PyBending::kappa_J)
      .def_readonly("h0_per_um", &PyBending::h0_per_um)
      .def_readonly("model", &PyBending::model)
      .def_readonly("dihedral_mapping", &PyBending::mapping)
      .def("__repr__", &PyBending::repr)
      .def(py::pickle(
          [](const PyBending& p) {
            return py::make_tuple(p.kappa_J, p.h0_per_um, p.model, p.mapping);
          },
          [](const py::tuple& t) {
            return make_bending(t[0].cast<double>(), t[1].cast<double>(), t[2].cast<BendingModel>(),
                                t[3].cast<DihedralMapping>());
          }));

  py::class_<PySteric>(m, "StericParameters",
                       "Steric face term 2C/((A/Abar)^q + eta): exponent q, regularisation eta.")
      .def(py::init([](double q, double eta) { return make_steric(q, eta); }), py::kw_only(),
           py::arg("q") = 1.0, py::arg("eta") = 0.005)
      .def_readonly("q", &PySteric::q)
      .def_readonly("eta", &PySteric::eta)
      .def("__repr__", &PySteric::repr)
      .def(py::pickle([](const PySteric& p) { return py::make_tuple(p.q, p.eta); },
                      [](const py::tuple& t) {
                        return make_steric(t[0].cast<double>(), t[1].cast<double>());
                      }));

  py::class_<PyContact>(m, "ContactParameters",
                        "Optical-tweezers bead contact: patch fraction per bead (of the area or of "
                        "the vertices) and the rule. level_patch=True takes the vertices at one "
                        "rest x together, the edge level at the fraction that meets the target "
                        "(the mirror-planes meshes' patch, as `rbc stretch --mesh-orientation "
                        "mirror-planes`).")
      .def(py::init([](double fraction, const py::object& rule, bool level_patch) {
             return make_contact(fraction, enum_arg<PatchRule>(rule, patch_rule_from_string),
                                 level_patch);
           }),
           py::kw_only(), py::arg("fraction") = 0.05, py::arg("rule") = "area",
           py::arg("level_patch") = false)
      .def_readonly("fraction", &PyContact::fraction)
      .def_readonly("rule", &PyContact::rule)
      .def_readonly("level_patch", &PyContact::level_patch)
      .def("__repr__", &PyContact::repr)
      .def(py::pickle(
          [](const PyContact& p) { return py::make_tuple(p.fraction, p.rule, p.level_patch); },
          [](const py::tuple& t) {
            return make_contact(t[0].cast<double>(), t[1].cast<PatchRule>(),
                                t.size() > 2 && t[2].cast<bool>());
          }));

  py::class_<PyConstraints>(m, "ConstraintParameters",
                            "Augmented-Lagrangian area/volume penalties (pN/um^3, pN/um^5) and the "
                            "relative drift at which the outer loop stops.")
      .def(py::init(&make_constraints), py::kw_only(), py::arg("area_stiffness_pN_per_um3") = 100.0,
           py::arg("volume_stiffness_pN_per_um5") = 100.0, py::arg("tolerance") = 1e-6)
      .def_property_readonly("area_stiffness_pN_per_um3",
                             [](const PyConstraints& p) { return p.lib.area_stiffness_pN_per_um3; })
      .def_property_readonly(
          "volume_stiffness_pN_per_um5",
          [](const PyConstraints& p) { return p.lib.volume_stiffness_pN_per_um5; })
      .def_property_readonly("tolerance", [](const PyConstraints& p) { return p.lib.tolerance; })
      .def("__repr__", &PyConstraints::repr)
      .def(py::pickle(
          [](const PyConstraints& p) {
            return py::make_tuple(p.lib.area_stiffness_pN_per_um3,
                                  p.lib.volume_stiffness_pN_per_um5, p.lib.tolerance);
          },
          [](const py::tuple& t) {
            return make_constraints(t[0].cast<double>(), t[1].cast<double>(), t[2].cast<double>());
          }));

  // rbc.ModelParameters (python/rbc/__init__.py) is a dataclass over these two functions: the
  // defaults come from the library (core/defaults.hpp and the parameter structs, which the
  // CLI's options use too) and the values are checked by the libraries' validate().
  m.def(
      "_model_defaults",
      [] {
        py::dict d;
        d["lbar_nm"] = defaults::kLbar_nm;
        d["lmax_nm"] = defaults::kLmax_nm;
        d["persistence_nm"] = defaults::kPersistence_nm;
        d["temperature_K"] = defaults::kWlcTemperature_K;
        d["kappa_J"] = defaults::kKappa_J;
        d["h0_per_um"] = BendingParameters{}.h0_per_um;
        d["q"] = StericParameters{}.q;
        d["eta"] = StericParameters{}.eta;
        d["contact"] = to_string(TweezersParameters{}.rule);
        d["contact_fraction"] = TweezersParameters{}.contact_fraction;
        d["bending"] = to_string(NetworkParameters{}.bending_model);
        d["dihedral_mapping"] =
            NetworkParameters{}.dihedral_mapping == DihedralMapping::sphere_matched ? "sphere"
                                                                                    : "li";
        return d;
      },
      "The defaults of rbc.ModelParameters (natural units), the CLI's.");
  m.def(
      "_model_objects",
      [](double lbar_nm, double lmax_nm, double persistence_nm, double temperature_K,
         double kappa_J, double h0_per_um, double q, double eta, const std::string& contact,
         double contact_fraction, const std::string& bending, const std::string& mapping) {
        const PyWlc w = make_wlc(persistence_nm, lmax_nm, lbar_nm, temperature_K,
                                 model_call({{"lbar_nm", lbar_nm},
                                             {"lmax_nm", lmax_nm},
                                             {"persistence_nm", persistence_nm},
                                             {"temperature_K", temperature_K}}));
        const std::string bcall = model_call({{"kappa_J", kappa_J}, {"h0_per_um", h0_per_um}});
        BendingModel model{};
        DihedralMapping map{};
        validated("ModelParameters(bending='" + bending + "')",
                  [&] { model = bending_model_from_string(bending); });
        validated("ModelParameters(dihedral_mapping='" + mapping + "')",
                  [&] { map = dihedral_mapping_from_string(mapping); });
        const PyBending b = make_bending(kappa_J, h0_per_um, model, map, bcall);
        // As the CLI's Model options (app/model_options.cpp): a cell needs kappa > 0 (the
        // library's BendingParameters allows 0 for flat test patches).
        validated(bcall, [&] {
          require_finite_in_range("bending rigidity kappa", "J", kappa_J, 0.0, kMaxKappa_J);
        });
        const PySteric s = make_steric(q, eta, model_call({{"q", q}, {"eta", eta}}));
        PatchRule rule{};
        validated("ModelParameters(contact='" + contact + "')",
                  [&] { rule = patch_rule_from_string(contact); });
        const PyContact c = make_contact(contact_fraction, rule, false,
                                         model_call({{"contact_fraction", contact_fraction}}));
        return py::make_tuple(w, b, s, c);
      },
      py::kw_only(), py::arg("lbar_nm"), py::arg("lmax_nm"), py::arg("persistence_nm"),
      py::arg("temperature_K"), py::arg("kappa_J"), py::arg("h0_per_um"), py::arg("q"),
      py::arg("eta"), py::arg("contact"), py::arg("contact_fraction"), py::arg("bending"),
      py::arg("dihedral_mapping"),
      "(WlcParameters, BendingParameters, StericParameters, ContactParameters) of the shared "
      "physics; ValueError naming the value and the limit (the libraries' validate()).");

  m.def(
      "thermal_energy_pNum",
      [](double temperature_K) {
        return units::thermal_energy_pNum(finite("temperature_K", temperature_K));
      },
      py::arg("temperature_K"), "kB T in pN um (kB = 1.38e-23 J/K as in the paper).");
}

}  // namespace rbc::py_bind
