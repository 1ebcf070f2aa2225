#pragma once
// Race-free parallel assembly of per-element gradient contributions: each thread sums
// into its own 3 x N buffer, buffers are added once at the end. With 2-8 threads this
// costs two passes over 3N doubles, far less than the element kernels themselves.
#include <omp.h>

#include "core/mesh.hpp"

namespace rbc {

/// Runs body(element, local_grad) for element in [0, count) in parallel and returns the
/// sum of the values it returns; when grad != nullptr each thread's local_grad (zeroed,
/// same shape as *grad) is added into *grad. body must only write into local_grad.
template <class Body>
double assemble_parallel(int count, Positions* grad, Body&& body) {
  double total = 0.0;
#pragma omp parallel reduction(+ : total)
  {
    Positions local;
    if (grad) local.setZero(3, grad->cols());
#pragma omp for schedule(static)
    for (int i = 0; i < count; ++i) total += body(i, local);
    if (grad) {
#pragma omp critical(rbc_assemble_parallel)
      *grad += local;
    }
  }
  return total;
}

}  // namespace rbc
