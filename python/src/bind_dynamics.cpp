// SPDX-License-Identifier: GPL-3.0-or-later
// The overdamped dynamics scenes of both models, as `rbc dynamics` runs them: the same library
// call (compare/dynamics_scene.hpp) with the same options, so the numbers are the CLI's bit for
// bit; the GIL is released while solving and the cancel hook polls Python's signal handlers
// before every time step and inside the static solves. rbc.dynamics() (python/rbc/_dynamics.py)
// wraps the raw result.
#include <map>

#include "common.hpp"
#include "compare/dynamics_scene.hpp"
#include "core/validation.hpp"

namespace rbc::py_bind {

namespace {

/// The run's options and result, read by rbc.DynamicsResult.
struct PyDynamics {
  DynamicsSceneOptions options;
  DynamicsSceneResult result;
  std::string summary_json;  ///< dynamics_summary_json(), the JSON of `rbc dynamics --json`
};

/// The library's quantities -> the keyword arguments of rbc.dynamics().
const std::map<std::string, std::string>& keyword_of_quantity() {
  static const std::map<std::string, std::string> names = {
      {"model", "model"},
      {"scene", "scene"},
      {"time scheme", "scheme"},
      {"time step dt", "dt_s"},
      {"duration", "duration_s"},
      {"membrane viscosity", "membrane_viscosity_pN_s_per_um"},
      {"dilatational ratio eta_d/eta_m", "dilatational_ratio"},
      {"force (discrete model)", "force_pN"},
      {"force (continuum model)", "force_pN"},
      {"step tolerance", "tolerance_pN_per_s"},
      {"regulariser (fraction of the p=2 law)", "regulariser"},
      {"normal drag", "normal_drag_pN_s_per_um3"},
      {"vertices", "vertices"},
      {"elements", "elements"},
      {"max halvings", "max_halvings"},
      {"step iterations", "step_iterations"},
  };
  return names;
}

/// Runs check(); the library's InvalidParameter becomes ValueError "<keyword> = <value>: <what
/// the library says>" (the quantity, the limit and the value).
template <class F>
void checked(F&& check) {
  try {
    check();
  } catch (const InvalidParameter& e) {
    const auto& names = keyword_of_quantity();
    const auto it = names.find(e.quantity());
    throw py::value_error((it == names.end() ? std::string("dynamics") : it->second) + " = " +
                          e.value() + ": " + e.what());
  }
}

py::array samples_column(const std::shared_ptr<PyDynamics>& d, double TrajectorySample::*field) {
  const auto& s = d->result.trajectory.samples;
  py::array_t<double> a(static_cast<py::ssize_t>(s.size()));
  auto v = a.mutable_unchecked<1>();
  for (std::size_t k = 0; k < s.size(); ++k) v(static_cast<py::ssize_t>(k)) = s[k].*field;
  a.attr("setflags")(py::arg("write") = false);
  return a;
}

}  // namespace

void bind_dynamics(py::module_& m) {
  py::class_<PyDynamics, std::shared_ptr<PyDynamics>>(m, "_DynamicsRun")
      .def_property_readonly("time_s",
                             [](const std::shared_ptr<PyDynamics>& d) {
                               return samples_column(d, &TrajectorySample::t_s);
                             })
      .def_property_readonly("axial_um",
                             [](const std::shared_ptr<PyDynamics>& d) {
                               return samples_column(d, &TrajectorySample::axial_um);
                             })
      .def_property_readonly("transverse_um",
                             [](const std::shared_ptr<PyDynamics>& d) {
                               return samples_column(d, &TrajectorySample::transverse_um);
                             })
      .def_property_readonly("energy_pNum",
                             [](const std::shared_ptr<PyDynamics>& d) {
                               return samples_column(d, &TrajectorySample::energy_pNum);
                             })
      .def_property_readonly("area_drift",
                             [](const std::shared_ptr<PyDynamics>& d) {
                               return samples_column(d, &TrajectorySample::area_drift);
                             })
      .def_property_readonly("volume_drift",
                             [](const std::shared_ptr<PyDynamics>& d) {
                               return samples_column(d, &TrajectorySample::volume_drift);
                             })
      .def_property_readonly("iterations",
                             [](const PyDynamics& d) {
                               const auto& s = d.result.trajectory.samples;
                               py::array_t<int> a(static_cast<py::ssize_t>(s.size()));
                               auto v = a.mutable_unchecked<1>();
                               for (std::size_t k = 0; k < s.size(); ++k)
                                 v(static_cast<py::ssize_t>(k)) = s[k].iterations;
                               return a;
                             })
      .def_property_readonly(
          "positions",
          [](const PyDynamics& d) {
            // (samples, N, 3) um: a copy of the positions at every sample.
            const auto& snaps = d.result.trajectory.snapshots;
            const py::ssize_t n = snaps.empty() ? 0 : snaps.front().cols();
            py::array_t<double> a({static_cast<py::ssize_t>(snaps.size()), n, py::ssize_t{3}});
            double* out = a.mutable_data();
            for (const auto& x : snaps) out = std::copy(x.data(), x.data() + 3 * n, out);
            return a;
          })
      .def_property_readonly(
          "faces",
          [](py::object self) { return rows_view(self.cast<PyDynamics&>().result.faces, self); })
      .def_property_readonly("converged",
                             [](const PyDynamics& d) { return d.result.trajectory.converged; })
      .def_property_readonly("status",
                             [](const PyDynamics& d) { return d.result.trajectory.status; })
      .def_property_readonly("halved_steps",
                             [](const PyDynamics& d) { return d.result.trajectory.halved_steps; })
      .def_property_readonly("wall_s",
                             [](const PyDynamics& d) { return d.result.trajectory.wall_s; })
      .def_property_readonly("vertices", [](const PyDynamics& d) { return d.result.vertices; })
      .def_property_readonly("elements", [](const PyDynamics& d) { return d.result.elements; })
      .def_property_readonly("law", [](const PyDynamics& d) { return d.result.law; })
      .def_readonly("summary_json", &PyDynamics::summary_json);

  m.def(
      "_dynamics",
      [](const std::string& model, const std::string& scene, const std::string& scheme,
         double force_pN, double eta, double dilatational_ratio, double duration_s, double dt_s,
         double tolerance, double normal_drag, double regulariser, int vertices, int elements,
         const py::object& order, int max_halvings, int step_iterations, const py::object& wlc,
         const py::object& bending, const py::object& steric, const py::object& contact,
         const py::object& constraints, py::object cancel, py::object progress) {
        auto d = std::make_shared<PyDynamics>();
        DynamicsSceneOptions& o = d->options;
        checked([&] {
          o.model = dynamics_model_from_string(model);
          o.scene = dynamics_scene_from_string(scene);
          o.scheme = time_scheme_from_string(scheme);
        });
        o.force_pN = finite("force_pN", force_pN);
        o.membrane_viscosity_pN_s_per_um = finite("membrane_viscosity_pN_s_per_um", eta);
        o.dilatational_ratio = finite("dilatational_ratio", dilatational_ratio);
        o.duration_s = finite("duration_s", duration_s);
        o.dt_s = finite("dt_s", dt_s);
        o.tolerance_pN_per_s = finite("tolerance_pN_per_s", tolerance);
        o.normal_drag_pN_s_per_um3 = finite("normal_drag_pN_s_per_um3", normal_drag);
        o.regulariser = finite("regulariser", regulariser);
        o.vertices = vertices;
        o.elements = elements;
        o.order = order_arg(order);
        o.max_halvings = max_halvings;
        o.step_iterations = step_iterations;
        // The network's parameters, as rbc.Network(mesh, wlc=..., ...) takes them (None =
        // the paper's defaults, which are `rbc dynamics`'s).
        o.network.wlc = wlc_or_default(wlc).lib;
        o.network.steric = steric_or_default(steric).lib;
        const PyBending b = bending_or_default(bending);
        o.network.bending = b.lib;
        o.network.bending_model = b.model;
        o.network.dihedral_mapping = b.mapping;
        o.network.tweezers = contact_or_default(contact).lib;
        o.network.constraints = constraints_or_default(constraints).lib;
        checked([&] { o.validate(); });
        const auto cb = make_callbacks(std::move(cancel), std::move(progress));
        o.cancel = make_cancel_check(cb);
        const ProgressSink sink = make_progress_sink(cb);
        d->result = run_released(cb, [&] { return run_dynamics_scene(o, sink); });
        o.cancel = {};  // holds the callbacks' state, which must be released with the GIL
        const DynamicsSceneResult& r = d->result;
        if (!r.static_converged)
          raise_convergence_error("the static equilibrium did not converge (" + r.static_status +
                                      "): largest vertex force residual " +
                                      format_scientific(r.static_residual_pN) + " pN",
                                  r.static_residual_pN, o.force_pN);
        if (!r.trajectory.converged)
          raise_convergence_error(r.trajectory.status, r.trajectory.residual_pN,
                                  r.force_dynamics_pN);
        d->summary_json = dynamics_summary_json(o, r).dump();
        return d;
      },
      py::arg("model"), py::arg("scene"), py::arg("scheme"), py::arg("force_pN"),
      py::arg("membrane_viscosity_pN_s_per_um"), py::arg("dilatational_ratio"),
      py::arg("duration_s"), py::arg("dt_s"), py::arg("tolerance_pN_per_s"),
      py::arg("normal_drag_pN_s_per_um3"), py::arg("regulariser"), py::arg("vertices"),
      py::arg("elements"), py::arg("order"), py::arg("max_halvings"), py::arg("step_iterations"),
      py::arg("wlc"), py::arg("bending"), py::arg("steric"), py::arg("contact"),
      py::arg("constraints"), py::arg("cancel"), py::arg("progress"));
}

}  // namespace rbc::py_bind
