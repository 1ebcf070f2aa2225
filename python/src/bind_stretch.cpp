// SPDX-License-Identifier: GPL-3.0-or-later
// The optical-tweezers stretch of both models, as `rbc stretch` runs it (app/cmd_stretch.cpp):
// same meshes, parameters, solver options and continuation; the GIL is released while solving
// and the solvers' cancel hooks poll Python's signal handlers.
#include "common.hpp"
#include "continuum/continuum_stretch.hpp"
#include "discrete/stretch.hpp"
#include "homogenise/invariant_laws.hpp"

namespace rbc::py_bind {

namespace {

void check_tolerance(const py::object& tolerance) {
  if (!tolerance.is_none() && !(finite("tolerance_pN", tolerance.cast<double>()) > 0))
    throw py::value_error("tolerance_pN must be positive, got " + num(tolerance.cast<double>()));
}
/// "none" or "mirror" (the CLI's --symmetry); ValueError otherwise.
Symmetry symmetry_arg(const std::string& name) {
  try {
    return symmetry_from_string(name);
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
}
int iterations_arg(const py::object& max_iterations, int fallback) {
  if (max_iterations.is_none()) return fallback;
  const int n = max_iterations.cast<int>();
  if (n < 1) throw py::value_error("max_iterations must be >= 1, got " + std::to_string(n));
  return n;
}

/// The library's check of a stretch's forces (StretchOptions / ContinuumOptions::validate with
/// the forces: finite and within the model's documented maximum), each force named by its index.
template <class Options>
void validate_forces(const Options& options, const std::vector<double>& forces) {
  for (std::size_t k = 0; k < forces.size(); ++k)
    validated("forces_pN[" + std::to_string(k) + "] = " + num(forces[k]),
              [&] { options.validate({forces[k]}); });
}

}  // namespace

void bind_stretch(py::module_& m) {
  py::class_<ConstraintMultipliers>(m, "ConstraintMultipliers",
                                    "Area tension lambda_A (pN/um) and volume pressure lambda_V "
                                    "(pN/um^2) of the augmented Lagrangian")
      .def(py::init([](double a, double v) {
             return ConstraintMultipliers{finite("area_pN_per_um", a),
                                          finite("volume_pN_per_um2", v)};
           }),
           py::arg("area_pN_per_um") = 0.0, py::arg("volume_pN_per_um2") = 0.0)
      .def_readonly("area_pN_per_um", &ConstraintMultipliers::area_pN_per_um)
      .def_readonly("volume_pN_per_um2", &ConstraintMultipliers::volume_pN_per_um2)
      .def("__repr__", [](const ConstraintMultipliers& c) {
        return "ConstraintMultipliers(area_pN_per_um=" + num(c.area_pN_per_um) +
               ", volume_pN_per_um2=" + num(c.volume_pN_per_um2) + ")";
      });

  // The library's per-force results; rbc.stretch() wraps them into rbc.StretchPoint records.
  py::class_<StretchPoint, std::shared_ptr<StretchPoint>>(m, "_DiscretePoint")
      .def_readonly("force_pN", &StretchPoint::force_pN)
      .def_readonly("axial_um", &StretchPoint::axial_um)
      .def_readonly("transverse_um", &StretchPoint::transverse_um)
      .def_readonly("energy_pNum", &StretchPoint::energy_pNum)
      .def_readonly("iterations", &StretchPoint::iterations)
      .def_readonly("factorisations", &StretchPoint::factorisations)
      .def_readonly("converged", &StretchPoint::converged)
      .def_readonly("residual_pN", &StretchPoint::residual_pN)
      .def_readonly("area_drift", &StretchPoint::area_drift)
      .def_readonly("volume_drift", &StretchPoint::volume_drift)
      .def_readonly("wall_s", &StretchPoint::wall_s)
      .def_readonly("vertices", &StretchPoint::vertices)
      .def_property_readonly("status", [](const StretchPoint& p) { return to_string(p.status); })
      .def_readonly("multipliers", &StretchPoint::multipliers)
      .def_readonly("stiffness_scale", &StretchPoint::stiffness_scale)
      .def_readonly("symmetry_order", &StretchPoint::symmetry_order)
      .def_readonly("symmetry_broken", &StretchPoint::symmetry_broken)
      .def_property_readonly("positions", [](py::object self) {
        return rows_view(self.cast<StretchPoint&>().x, self, true);
      });

  py::class_<ContinuumStretchPoint, std::shared_ptr<ContinuumStretchPoint>>(m, "_ContinuumPoint")
      .def_readonly("force_pN", &ContinuumStretchPoint::force_pN)
      .def_readonly("axial_um", &ContinuumStretchPoint::axial_um)
      .def_readonly("transverse_um", &ContinuumStretchPoint::transverse_um)
      .def_readonly("energy_pNum", &ContinuumStretchPoint::energy_pNum)
      .def_readonly("iterations", &ContinuumStretchPoint::iterations)
      .def_readonly("substeps", &ContinuumStretchPoint::substeps)
      .def_readonly("converged", &ContinuumStretchPoint::converged)
      .def_readonly("residual_pN", &ContinuumStretchPoint::residual_pN)
      .def_readonly("area_drift", &ContinuumStretchPoint::area_drift)
      .def_readonly("volume_drift", &ContinuumStretchPoint::volume_drift)
      .def_readonly("wall_s", &ContinuumStretchPoint::wall_s)
      .def_readonly("vertices", &ContinuumStretchPoint::vertices)
      .def_readonly("elements", &ContinuumStretchPoint::elements)
      .def_readonly("symmetry_order", &ContinuumStretchPoint::symmetry_order)
      .def_readonly("symmetry_broken", &ContinuumStretchPoint::symmetry_broken)
      .def_property_readonly("status",
                             [](const ContinuumStretchPoint& p) { return to_string(p.status); })
      .def_readonly("multipliers", &ContinuumStretchPoint::multipliers)
      .def_property_readonly("positions",
                             [](py::object self) {
                               return rows_view(self.cast<ContinuumStretchPoint&>().x, self, true);
                             })
      .def_property_readonly("fields", [](py::object self) {
        const ElementFields& f = self.cast<ContinuumStretchPoint&>().fields;
        py::dict d;
        d["I1"] = vector_view(f.i1, self);
        d["I2"] = vector_view(f.i2, self);
        d["tension_max_pN_per_um"] = vector_view(f.tension_max_pN_per_um, self);
        d["tension_min_pN_per_um"] = vector_view(f.tension_min_pN_per_um, self);
        return d;
      });

  m.def(
      "_stretch_discrete",
      [](std::shared_ptr<PyNetwork> n, const py::handle& forces, const py::object& tolerance,
         const py::object& max_iterations, const std::string& symmetry, py::object cancel,
         py::object progress) {
        const std::vector<double> f = forces_arg(forces);
        check_tolerance(tolerance);
        StretchOptions so;
        validate_forces(so, f);
        so.symmetry = symmetry_arg(symmetry);
        if (!tolerance.is_none()) so.minimiser.force_tolerance = tolerance.cast<double>();
        so.minimiser.max_iterations = iterations_arg(max_iterations, 50000);
        const auto cb = make_callbacks(std::move(cancel), std::move(progress));
        so.minimiser.cancel = make_cancel_check(cb);
        const ProgressSink sink = make_progress_sink(cb);
        std::vector<StretchPoint> pts =
            run_released(cb, [&] { return run_stretch(*n->net, f, so, sink); });
        std::vector<std::shared_ptr<StretchPoint>> out;
        for (auto& p : pts) out.push_back(std::make_shared<StretchPoint>(std::move(p)));
        py::dict info;
        info["polls"] = cb->polls.load();
        return py::make_tuple(out, info);
      },
      py::arg("network"), py::arg("forces_pN"), py::arg("tolerance_pN"), py::arg("max_iterations"),
      py::arg("symmetry"), py::arg("cancel"), py::arg("progress"));

  m.def(
      "_stretch_continuum",
      [](int elements, const py::object& order, const py::object& wlc, const py::object& bending,
         const py::object& steric, const py::object& contact, const py::handle& forces,
         const py::object& tolerance, const py::object& max_iterations, const std::string& symmetry,
         const std::string& mesh_orientation, py::object cancel, py::object progress) {
        const std::vector<double> f = forces_arg(forces);
        validate_forces(ContinuumOptions{}, f);
        const PyWlc w = wlc_or_default(wlc);
        const PyBending b = bending_or_default(bending);
        const PySteric s = steric_or_default(steric);
        const PyContact c = contact_or_default(contact);
        const WlcExpansion e = order_arg(order);
        const TriangulationOrientation orientation =
            triangulation_orientation_from_string(mesh_orientation);
        if (elements < kMinContinuumElements || elements > kMaxContinuumElements)
          throw py::value_error("elements = " + std::to_string(elements) +
                                " is out of range; expected " +
                                std::to_string(kMinContinuumElements) + " to " +
                                std::to_string(kMaxContinuumElements));
        check_tolerance(tolerance);
        ContinuumOptions co;
        // As the CLI: Newton iterations capped at 1000; its force tolerance (1e-6 pN) unless given.
        co.newton.max_iterations = std::min(iterations_arg(max_iterations, 50000), 1000);
        if (!tolerance.is_none()) co.newton.force_tolerance_pN = tolerance.cast<double>();
        co.newton.symmetry = symmetry_arg(symmetry);
        const auto cb = make_callbacks(std::move(cancel), std::move(progress));
        co.newton.cancel = make_cancel_check(cb);
        co.lbfgs.cancel = co.newton.cancel;
        co.validate(f);
        const ProgressSink sink = make_progress_sink(cb);
        auto mesh = std::make_shared<PyMesh>();
        std::string law_name;
        std::vector<ContinuumStretchPoint> pts = run_released(cb, [&] {
          mesh->mesh = make_continuum_mesh(elements, 0, orientation, &mesh->quality);
          ContinuumParameters cp;
          cp.bending = b.lib;
          cp.tweezers = c.lib;  // rbc.stretch() asks for the level patch with mirror-planes
          const ContinuumModel model =
              build_continuum_model(mesh->mesh, make_membrane_law(w.lib, s.lib, e), cp);
          law_name = model.law.name;
          return run_continuum_stretch(model, f, co, sink);
        });
        std::vector<std::shared_ptr<ContinuumStretchPoint>> out;
        for (auto& p : pts) out.push_back(std::make_shared<ContinuumStretchPoint>(std::move(p)));
        py::dict info;
        info["polls"] = cb->polls.load();
        info["mesh"] = mesh;
        info["law"] = law_name;
        return py::make_tuple(out, info);
      },
      py::arg("elements"), py::arg("order"), py::arg("wlc"), py::arg("bending"), py::arg("steric"),
      py::arg("contact"), py::arg("forces_pN"), py::arg("tolerance_pN"), py::arg("max_iterations"),
      py::arg("symmetry"), py::arg("mesh_orientation"), py::arg("cancel"), py::arg("progress"));

  m.def(
      "_validate_forces",
      [](const std::string& model, const py::handle& forces) {
        const std::vector<double> f = forces_arg(forces);
        if (model == "discrete")
          validate_forces(StretchOptions{}, f);
        else
          validate_forces(ContinuumOptions{}, f);
      },
      py::arg("model"), py::arg("forces_pN"),
      "The forces' check of a stretch of the model ('discrete' or 'continuum'), before any mesh "
      "is built: ValueError unless each is finite and within the model's documented maximum.");
}

}  // namespace rbc::py_bind
