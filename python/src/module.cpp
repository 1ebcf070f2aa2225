// SPDX-License-Identifier: GPL-3.0-or-later
// The `_rbc` extension module: bindings over the libraries (core, discrete, homogenise,
// continuum); the pure-Python package `rbc` (python/rbc/) wraps it.
#include "common.hpp"
#include "core/blas_threads.hpp"
#include "core/version.hpp"

PYBIND11_MODULE(_rbc, m) {
  namespace py = pybind11;
  using namespace rbc::py_bind;
  m.doc() = "rbc: multiscale red blood cell mechanics (Hartmann 2008), compiled core";
  // The version `rbc --version` prints (core/version.hpp); rbc.__version__ re-exports it.
  m.attr("__version__") = rbc::version_string();
  // A solve that did not converge, raised only when asked (check=True); carries residual_pN.
  static py::exception<std::runtime_error> convergence_error(m, "ConvergenceError",
                                                             PyExc_RuntimeError);
  convergence_error.attr("__doc__") =
      "A solve that did not converge (a RuntimeError), raised only with check=True: "
      ".residual_pN (largest net vertex force at the end, pN), .force_pN (the force, pN) and, "
      "from rbc.stretch, .result (the StretchResult with every point).";
  // A cancelled solve (Ctrl-C or a cancel callback) surfaces as KeyboardInterrupt.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const rbc::Cancelled& e) {
      PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
    }
  });
  bind_parameters(m);
  bind_mesh(m);
  bind_network(m);
  bind_stretch(m);
  bind_homogenise(m);
  bind_mc(m);
  bind_infer(m);
  bind_dynamics(m);
  m.def(
      "blas_info",
      [] {
        const rbc::BlasInfo b = rbc::blas_info();
        py::dict d;
        d["library"] = b.library;
        d["core"] = b.core;
        d["config"] = b.config;
        d["threads"] = b.threads;
        return d;
      },
      "The BLAS this process runs, as `rbc stretch --out`'s run.json records it: dict with "
      "'library' ('OpenBLAS' or 'unknown'), 'core' (OpenBLAS's kernel, e.g. 'Haswell': set by "
      "OPENBLAS_CORETYPE or the CPU when the library was loaded), 'config' (its build) and "
      "'threads' (its thread count now; the factorisations run on one).");
}
