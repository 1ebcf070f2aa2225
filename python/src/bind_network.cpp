// SPDX-License-Identifier: GPL-3.0-or-later
// The spectrin network of Model 1 (discrete/network.hpp): its prepared state, the free energy
// with gradient, and the sparse Hessian (discrete/network_hessian.hpp) for users' own solvers.
#include "common.hpp"
#include "continuum/continuum_model.hpp"
#include "core/geometry.hpp"
#include "discrete/network_hessian.hpp"

namespace rbc::py_bind {

namespace {

LoadState load_of(double force_pN, double area_multiplier, double volume_multiplier,
                  double stiffness_scale) {
  finite("force_pN", force_pN);
  finite("area_multiplier_pN_per_um", area_multiplier);
  finite("volume_multiplier_pN_per_um2", volume_multiplier);
  if (!(finite("stiffness_scale", stiffness_scale) > 0))
    throw py::value_error("stiffness_scale must be finite and > 0, got " + num(stiffness_scale));
  LoadState load;
  load.force_pN = force_pN;
  load.multipliers = {area_multiplier, volume_multiplier};
  load.stiffness_scale = stiffness_scale;
  return load;
}

/// The gradient in the shape the positions came in: (N, 3) or (3N,).
py::array shaped_like(Positions&& g, const py::handle& positions) {
  py::array out = owning_rows(std::move(g));
  if (py::array::ensure(positions).ndim() == 1) return out.attr("reshape")(-1);
  return out;
}

std::shared_ptr<PyNetwork> make_network(std::shared_ptr<PyMesh> mesh, const py::object& wlc,
                                        const py::object& bending, const py::object& steric,
                                        const py::object& contact, const py::object& constraints,
                                        const py::object& expansion) {
  auto n = std::make_shared<PyNetwork>();
  n->mesh = mesh;
  n->wlc = wlc_or_default(wlc);
  n->bending = bending_or_default(bending);
  n->steric = steric_or_default(steric);
  n->contact = contact_or_default(contact);
  n->constraints = constraints_or_default(constraints);
  n->expansion = order_arg(expansion);
  const NetworkParameters p = n->params();
  n->net = run_released(
      nullptr, [&] { return std::make_shared<const Network>(build_network(mesh->mesh, p)); });
  return n;
}

}  // namespace

void bind_network(py::module_& m) {
  py::class_<PyNetwork, std::shared_ptr<PyNetwork>>(
      m, "Network",
      "The spectrin network on a rest mesh (MODEL.md section 2): per-link rest lengths and "
      "per-face rest areas taken from the mesh (every element stress-free at its own reference), "
      "material constants, bead patches. Immutable; share it between threads freely.")
      .def(py::init([](std::shared_ptr<PyMesh> mesh, const py::object& parameters,
                       const py::object& wlc, const py::object& bending, const py::object& steric,
                       const py::object& contact, const py::object& constraints,
                       const py::object& expansion) {
             if (parameters.is_none())
               return make_network(std::move(mesh), wlc, bending, steric, contact, constraints,
                                   expansion);
             if (!wlc.is_none() || !bending.is_none() || !steric.is_none() || !contact.is_none())
               throw py::value_error(
                   "give either parameters (rbc.ModelParameters) or wlc, bending, steric, "
                   "contact, not both");
             return make_network(std::move(mesh), parameters.attr("wlc_parameters"),
                                 parameters.attr("bending_parameters"),
                                 parameters.attr("steric_parameters"),
                                 parameters.attr("contact_parameters"), constraints, expansion);
           }),
           py::arg("mesh"), py::kw_only(), py::arg("parameters") = py::none(),
           py::arg("wlc") = py::none(), py::arg("bending") = py::none(),
           py::arg("steric") = py::none(), py::arg("contact") = py::none(),
           py::arg("constraints") = py::none(), py::arg("expansion") = "full",
           "Network(mesh, parameters=ModelParameters(), constraints=ConstraintParameters(), "
           "expansion='full'), or with the physics as wlc=WlcParameters(), "
           "bending=BendingParameters(), steric=StericParameters(), contact=ContactParameters() "
           "instead of parameters; None = defaults. mesh: an rbc.Mesh in um.")
      .def_readonly("mesh", &PyNetwork::mesh, "the rest mesh (rbc.Mesh, um)")
      .def_readonly("wlc", &PyNetwork::wlc, "rbc.WlcParameters (nm, K)")
      .def_readonly("bending", &PyNetwork::bending, "rbc.BendingParameters (J, 1/um)")
      .def_readonly("steric", &PyNetwork::steric, "rbc.StericParameters (dimensionless)")
      .def_readonly("contact", &PyNetwork::contact, "rbc.ContactParameters (dimensionless)")
      .def_readonly("constraints", &PyNetwork::constraints,
                    "rbc.ConstraintParameters (pN/um^3, pN/um^5)")
      .def_readonly("expansion", &PyNetwork::expansion, "rbc.Order of the WLC density V")
      .def_property_readonly(
          "num_vertices", [](const PyNetwork& n) { return n.net->topo.num_vertices; },
          "vertex count N")
      .def_property_readonly(
          "rest_positions",
          [](py::object self) { return rows_view(self.cast<PyNetwork&>().net->rest, self); },
          "(N, 3) rest positions X in um (read-only view)")
      .def_property_readonly(
          "faces",
          [](py::object self) { return rows_view(self.cast<PyNetwork&>().net->topo.faces, self); },
          "(F, 3) int32 faces (read-only view)")
      .def_property_readonly(
          "edges",
          [](py::object self) { return rows_view(self.cast<PyNetwork&>().net->topo.edges, self); },
          "(E, 2) int32 links (read-only view)")
      .def_property_readonly(
          "lbar_um",
          [](py::object self) { return vector_view(self.cast<PyNetwork&>().net->lbar_um, self); },
          "(E,) rest link lengths Lbar_e in um (read-only view)")
      .def_property_readonly(
          "abar_um2",
          [](py::object self) { return vector_view(self.cast<PyNetwork&>().net->abar_um2, self); },
          "(F,) rest face areas Abar_f in um^2 (read-only view)")
      .def_property_readonly(
          "area0_um2", [](const PyNetwork& n) { return n.net->area0_um2; },
          "rest area A0 the area constraint holds (um^2)")
      .def_property_readonly(
          "volume0_um3", [](const PyNetwork& n) { return n.net->volume0_um3; },
          "rest volume V0 the volume constraint holds (um^3)")
      .def_property_readonly(
          "steric_C_pN_per_um", [](const PyNetwork& n) { return n.net->steric_C_pN_per_um; },
          "steric constant C that makes the rest shape stress-free (pN/um)")
      .def_property_readonly(
          "dihedral_kb_pNum", [](const PyNetwork& n) { return n.net->dihedral_kb_pNum; },
          "dihedral bending stiffness k_b (pN um)")
      .def_property_readonly(
          "wlc_x0", [](const PyNetwork& n) { return n.net->wlc.x0; },
          "Lbar/Lmax of the density V (0.31546 for the defaults)")
      .def_property_readonly(
          "contact_vertices",
          [](const PyNetwork& n) {
            return py::array_t<int>(static_cast<py::ssize_t>(n.net->patch.vertex.size()),
                                    n.net->patch.vertex.data());
          },
          "bead-bound vertex indices (copy)")
      .def_property_readonly(
          "contact_shares",
          [](const PyNetwork& n) {
            return py::array_t<double>(static_cast<py::ssize_t>(n.net->patch.share.size()),
                                       n.net->patch.share.data());
          },
          "signed force shares of the bound vertices along +x (each bead sums to +-1; copy)")
      .def_property_readonly(
          "contact_area_um2",
          [](const PyNetwork& n) {
            return py::make_tuple(n.net->patch.area_plus_um2, n.net->patch.area_minus_um2);
          },
          "(+x bead, -x bead) contact patch areas (um^2)")
      .def(
          "largest_rest_inplane_force_pN",
          [](const PyNetwork& n) { return largest_rest_inplane_force_pN(*n.net); },
          "Largest in-plane (links + steric) vertex force at the rest shape (pN)")
      .def(py::pickle(
          [](const PyNetwork& n) {
            return py::make_tuple(n.mesh, n.wlc, n.bending, n.steric, n.contact, n.constraints,
                                  n.expansion);
          },
          [](const py::tuple& t) {  // rebuilt from the mesh and parameters (deterministic)
            return make_network(t[0].cast<std::shared_ptr<PyMesh>>(), t[1], t[2], t[3], t[4], t[5],
                                t[6]);
          }))
      .def("__repr__", [](const PyNetwork& n) {
        return "Network(vertices=" + std::to_string(n.net->topo.num_vertices) + ", " +
               n.wlc.repr() + ", " + n.bending.repr() + ", " + n.steric.repr() + ", " +
               n.contact.repr() + ")";
      });

  m.def(
      "network_energy",
      [](const PyNetwork& n, const py::handle& positions, double force_pN, double lambda_a,
         double lambda_v, double stiffness_scale) {
        const Positions x = positions_from_array(positions, n.net->topo.num_vertices, "positions");
        const LoadState load = load_of(force_pN, lambda_a, lambda_v, stiffness_scale);
        Positions grad;
        const double e =
            run_released(nullptr, [&] { return network_energy(*n.net, x, load, &grad); });
        if (!std::isfinite(e)) grad.setConstant(3, x.cols(), std::nan(""));
        return py::make_tuple(e, shaped_like(std::move(grad), positions));
      },
      py::arg("network"), py::arg("positions"), py::kw_only(), py::arg("force_pN") = 0.0,
      py::arg("area_multiplier_pN_per_um") = 0.0, py::arg("volume_multiplier_pN_per_um2") = 0.0,
      py::arg("stiffness_scale") = 1.0,
      "(energy_pNum, gradient_pN) of the total free energy F = links + steric + bending + "
      "lambda_A (A - A0) + s kA/2 (A - A0)^2 + lambda_V (V - V0) + s kV/2 (V - V0)^2 - tweezer "
      "work at bead force force_pN. positions (N, 3) or flat (3N,) in um; the gradient has the "
      "same shape. Infeasible positions (a link at Lmax, a collapsed face) give energy inf and a "
      "NaN gradient.");

  m.def(
      "network_energy_parts",
      [](const PyNetwork& n, const py::handle& positions, double force_pN, double lambda_a,
         double lambda_v, double stiffness_scale) {
        const Positions x = positions_from_array(positions, n.net->topo.num_vertices, "positions");
        const LoadState load = load_of(force_pN, lambda_a, lambda_v, stiffness_scale);
        EnergyBreakdown p;
        const double e =
            run_released(nullptr, [&] { return network_energy(*n.net, x, load, nullptr, &p); });
        py::dict d;
        d["links_pNum"] = p.links;
        d["steric_pNum"] = p.steric;
        d["bending_pNum"] = p.bending;
        d["constraints_pNum"] = p.constraints;
        d["tweezers_pNum"] = p.tweezers;
        d["total_pNum"] = e;
        return d;
      },
      py::arg("network"), py::arg("positions"), py::kw_only(), py::arg("force_pN") = 0.0,
      py::arg("area_multiplier_pN_per_um") = 0.0, py::arg("volume_multiplier_pN_per_um2") = 0.0,
      py::arg("stiffness_scale") = 1.0,
      "Energy of each term in pN um as a dict: links_pNum, steric_pNum, bending_pNum, "
      "constraints_pNum (multipliers and penalties), tweezers_pNum (minus the bead work) and "
      "total_pNum (their sum, network_energy's value).");

  m.def(
      "_network_hessian",
      [](const PyNetwork& n, const py::handle& positions, double lambda_a, double lambda_v,
         double stiffness_scale, bool exact, double shift_fraction) {
        const Positions x = positions_from_array(positions, n.net->topo.num_vertices, "positions");
        const LoadState load = load_of(0.0, lambda_a, lambda_v, stiffness_scale);
        NetworkHessianOptions o;
        o.project = !exact;
        o.hinge_curvature = exact;
        o.shift_fraction = finite("shift_fraction", shift_fraction);
        validated("network_hessian(shift_fraction=" + num(shift_fraction) + ")",
                  [&] { o.validate(); });
        struct Out {
          Eigen::SparseMatrix<double> full;
          Positions grad_area, grad_volume;
          double weight_area = 0, weight_volume = 0;
        };
        Out out = run_released(nullptr, [&] {
          const Network& net = *n.net;
          ConstraintValues c = evaluate_constraints(x, net.topo);
          const double s = load.stiffness_scale;
          ConstraintCurvature cc;
          cc.tension_pN_per_um =
              load.multipliers.area_pN_per_um +
              s * net.constraints.area_stiffness_pN_per_um3 * (c.area_um2 - net.area0_um2);
          cc.pressure_pN_per_um2 =
              load.multipliers.volume_pN_per_um2 +
              s * net.constraints.volume_stiffness_pN_per_um5 * (c.volume_um3 - net.volume0_um3);
          NetworkHessian h(net, o);
          Out r;
          // Lower triangle in 3 x 3 blocks with full diagonal blocks: the full symmetric matrix
          // from the entries on and below the diagonal.
          r.full = h.assemble(x, cc).selfadjointView<Eigen::Lower>();
          r.full.makeCompressed();
          r.grad_area = std::move(c.grad_area);
          r.grad_volume = std::move(c.grad_volume);
          r.weight_area = s * net.constraints.area_stiffness_pN_per_um3;
          r.weight_volume = s * net.constraints.volume_stiffness_pN_per_um5;
          return r;
        });
        // Column-major (CSC) arrays; the matrix is symmetric, so they are also its CSR arrays.
        const auto& H = out.full;
        py::dict d;
        d["data"] = py::array_t<double>(H.nonZeros(), H.valuePtr());
        d["indices"] = py::array_t<int>(H.nonZeros(), H.innerIndexPtr());
        d["indptr"] = py::array_t<int>(H.outerSize() + 1, H.outerIndexPtr());
        d["size"] = H.rows();
        d["area_gradient_um"] = owning_rows(std::move(out.grad_area));
        d["volume_gradient_um2"] = owning_rows(std::move(out.grad_volume));
        d["area_weight_pN_per_um3"] = out.weight_area;
        d["volume_weight_pN_per_um5"] = out.weight_volume;
        return d;
      },
      py::arg("network"), py::arg("positions"), py::arg("area_multiplier_pN_per_um"),
      py::arg("volume_multiplier_pN_per_um2"), py::arg("stiffness_scale"), py::arg("exact"),
      py::arg("shift_fraction"));
}

}  // namespace rbc::py_bind
