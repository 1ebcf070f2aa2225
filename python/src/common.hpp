// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Shared helpers of the Python bindings: numpy views of Eigen storage (no copies where the
// layout allows), enum arguments given as strings, the cancel hook and the parameter objects
// the Python edge takes in natural units (nm, J, K, pN) and converts once (core/units.hpp).
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <memory>
#include <optional>
#include <string>

#include "core/mesh.hpp"
#include "core/progress.hpp"
#include "core/rest_shape.hpp"
#include "discrete/network.hpp"

namespace rbc::py_bind {

namespace py = pybind11;

// ---- numpy views ----------------------------------------------------------------------------

/// A (cols, rows) C-contiguous numpy view of a column-major Eigen matrix (3 x N positions ->
/// (N, 3)), sharing its memory; `base` keeps the owner alive. Read-only unless writeable.
template <class Matrix>
py::array rows_view(const Matrix& m, py::handle base, bool writeable = false) {
  using Scalar = typename Matrix::Scalar;
  const auto rows = static_cast<py::ssize_t>(m.rows()), cols = static_cast<py::ssize_t>(m.cols());
  py::array_t<Scalar> a(
      {cols, rows},
      {static_cast<py::ssize_t>(sizeof(Scalar)) * rows, static_cast<py::ssize_t>(sizeof(Scalar))},
      m.data(), base);
  if (!writeable) a.attr("setflags")(py::arg("write") = false);
  return a;
}

/// A 1-D view of a vector.
template <class Vector>
py::array vector_view(const Vector& v, py::handle base, bool writeable = false) {
  using Scalar = typename Vector::Scalar;
  py::array_t<Scalar> a({static_cast<py::ssize_t>(v.size())}, {sizeof(Scalar)}, v.data(), base);
  if (!writeable) a.attr("setflags")(py::arg("write") = false);
  return a;
}

/// Moves an Eigen object to the heap and returns a writeable numpy view owning it (no copy).
template <class Matrix>
py::array owning_rows(Matrix&& m) {
  auto* p = new std::decay_t<Matrix>(std::forward<Matrix>(m));
  py::capsule owner(p, [](void* q) { delete static_cast<std::decay_t<Matrix>*>(q); });
  return rows_view(*p, owner, true);
}
template <class Vector>
py::array owning_vector(Vector&& v) {
  auto* p = new std::decay_t<Vector>(std::forward<Vector>(v));
  py::capsule owner(p, [](void* q) { delete static_cast<std::decay_t<Vector>*>(q); });
  return vector_view(*p, owner, true);
}

/// Positions (3 x N, um) from a numpy array of shape (N, 3) or (3N,) (any float dtype; one
/// copy into the library's storage). Throws ValueError naming the shape when expected_n >= 0
/// and the vertex count differs, and (require_finite) for a NaN or inf coordinate.
Positions positions_from_array(const py::handle& array, int expected_n, const char* what);

/// Repr of a float as Python prints it (for error messages naming a value).
std::string num(double v);

/// The one finiteness check of every number a binding takes: returns `value` when it is finite,
/// otherwise raises ValueError "<what> = nan is not allowed: expected a finite number". Ranges
/// are the library's validate()'s to check; this only keeps NaN and inf from reaching it (or
/// reaching code that has no validate(), e.g. an energy evaluation).
double finite(const std::string& what, double value);

/// The same for every value of an array (data[0, n)): ValueError naming the first non-finite
/// entry by its flat index ("positions: entry 7 of 750 is nan; expected finite values").
void require_finite(const std::string& what, const double* data, std::size_t n);

/// Runs check(); a std::invalid_argument from the library's validation becomes a ValueError
/// prefixed by `call` (the Python call with its values in natural units).
template <class F>
void validated(const std::string& call, F&& check) {
  try {
    check();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(call + ": " + e.what());
  }
}

// ---- enums given as strings -----------------------------------------------------------------

/// An enum argument: an instance of the bound enum, its member name ("phi_minimised"), or the
/// CLI spelling parsed by the library ("phi-minimised"; an unknown name raises ValueError with
/// the library's message naming the value and the choices).
template <class E, class Parse>
E enum_arg(const py::handle& h, Parse&& parse) {
  if (py::isinstance<py::str>(h)) {
    const std::string s = h.cast<std::string>();
    const py::object type = py::type::of<E>();
    const py::dict members = type.attr("__members__");
    if (members.contains(s)) return members[py::str(s)].template cast<E>();
    return parse(s);
  }
  return h.cast<E>();
}

WlcExpansion order_arg(const py::handle& h);  ///< also accepts the ints 2, 3, 4

// ---- cancel hook and progress ---------------------------------------------------------------

/// State shared by the CancelCheck and ProgressSink handed to the library (which copy them
/// freely, without the GIL: only this shared_ptr is copied, never a Python reference). It must be
/// destroyed with the GIL held.
struct CallbackState {
  py::object cancel;                           ///< None or a callable returning true to cancel
  py::object progress;                         ///< None or a callable taking a str
  std::optional<py::error_already_set> error;  ///< raised by a signal handler or a callback
  std::atomic<long> polls{0};                  ///< times the library polled the hook
};

/// The library's cancel hook: re-acquires the GIL, runs Python's signal handlers
/// (PyErr_CheckSignals: Ctrl-C raises KeyboardInterrupt there) and the user's callable.
CancelCheck make_cancel_check(const std::shared_ptr<CallbackState>& s);
ProgressSink make_progress_sink(const std::shared_ptr<CallbackState>& s);
std::shared_ptr<CallbackState> make_callbacks(py::object cancel, py::object progress);

/// Runs f() with the GIL released. rbc::Cancelled re-raises the Python error that caused it
/// (KeyboardInterrupt from Ctrl-C, an exception from a callback) or KeyboardInterrupt.
template <class F>
auto run_released(const std::shared_ptr<CallbackState>& s, F&& f) -> decltype(f()) {
  try {
    py::gil_scoped_release release;
    return f();
  } catch (const Cancelled&) {
    if (s && s->error) {
      py::error_already_set e = std::move(*s->error);
      s->error.reset();
      throw e;
    }
    PyErr_SetString(PyExc_KeyboardInterrupt, "cancelled by the caller");
    throw py::error_already_set();
  }
}

/// Raises rbc.ConvergenceError (a RuntimeError) with residual_pN and force_pN attributes.
[[noreturn]] void raise_convergence_error(const std::string& message, double residual_pN,
                                          double force_pN);

// ---- parameter objects (natural units, converted once) --------------------------------------

struct PyWlc {
  double persistence_nm = defaults::kPersistence_nm, lmax_nm = defaults::kLmax_nm,
         lbar_nm = defaults::kLbar_nm, temperature_K = defaults::kWlcTemperature_K;
  WlcParameters lib;  ///< internal units, validated
  std::string repr() const;
};
struct PyBending {
  double kappa_J = defaults::kKappa_J, h0_per_um = 0.0;
  BendingModel model = BendingModel::juelicher;
  DihedralMapping mapping = DihedralMapping::sphere_matched;
  BendingParameters lib;
  std::string repr() const;
};
struct PySteric {
  double q = 1.0, eta = 0.005;
  StericParameters lib;
  std::string repr() const;
};
struct PyContact {
  double fraction = 0.05;
  PatchRule rule = PatchRule::by_area;
  bool level_patch = false;  ///< TweezersParameters::keep_equal_x_together
  TweezersParameters lib;
  std::string repr() const;
};
struct PyConstraints {
  ConstraintParameters lib;
  std::string repr() const;
};

/// The parameter objects, validated by the library's validate(); a ValueError is prefixed by
/// `call` (the Python call that gave the values; empty: the object's repr).
PyWlc make_wlc(double persistence_nm, double lmax_nm, double lbar_nm, double temperature_K,
               const std::string& call = {});
PyBending make_bending(double kappa_J, double h0_per_um, BendingModel model,
                       DihedralMapping mapping, const std::string& call = {});
PySteric make_steric(double q, double eta, const std::string& call = {});
PyContact make_contact(double fraction, PatchRule rule, bool level_patch = false,
                       const std::string& call = {});
PyConstraints make_constraints(double area_stiffness, double volume_stiffness, double tolerance);

/// A triangle mesh with its quality report.
struct PyMesh {
  TriMesh mesh;
  MeshQualityReport quality;
};

/// A prepared network (immutable) and the parameters it was built from.
struct PyNetwork {
  std::shared_ptr<const Network> net;
  std::shared_ptr<PyMesh> mesh;
  PyWlc wlc;
  PyBending bending;
  PySteric steric;
  PyContact contact;
  PyConstraints constraints;
  WlcExpansion expansion = WlcExpansion::full;
  NetworkParameters params() const;
};

/// The parameter objects from Python arguments (None = defaults).
PyWlc wlc_or_default(const py::object& o);
PyBending bending_or_default(const py::object& o);
PySteric steric_or_default(const py::object& o);
PyContact contact_or_default(const py::object& o);
PyConstraints constraints_or_default(const py::object& o);

/// Forces in pN from a Python sequence: finite and >= 0, not empty (the CLI's rule). The
/// model's maximum is checked by the library (StretchOptions / ContinuumOptions::validate).
std::vector<double> forces_arg(const py::handle& forces);

void bind_parameters(py::module_& m);
void bind_mesh(py::module_& m);
void bind_network(py::module_& m);
void bind_stretch(py::module_& m);
void bind_homogenise(py::module_& m);
void bind_mc(py::module_& m);
void bind_infer(py::module_& m);
void bind_dynamics(py::module_& m);

}  // namespace rbc::py_bind
