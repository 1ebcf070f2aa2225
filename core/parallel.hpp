#pragma once
// Deterministic parallel assembly of per-element contributions (issue 10): the elements
// are split into fixed-size chunks that depend on the element count only, never on the
// thread count; chunk 0 accumulates straight into the caller's gradient, every other chunk
// into its own zeroed buffer, and the chunks are then added in index order (per vertex,
// in parallel over vertices). So the result is bit-identical with 1, 2 or more threads,
// and problems of one chunk (fewer than kChunkElements elements: the small meshes of
// parameter sweeps) run serially without waking a thread or allocating.
#include <omp.h>

#include <algorithm>
#include <vector>

#include "core/mesh.hpp"

namespace rbc {

/// Elements per chunk, and the most chunks one assembly is split into (their buffers cost
/// one pass over 3N doubles each: more chunks than cores buy nothing on this machine).
inline constexpr int kChunkElements = 4096;
inline constexpr int kMaxChunks = 4;

/// Number of chunks for `count` elements (a function of the count only).
inline int assembly_chunks(int count) {
  return std::clamp((count + kChunkElements - 1) / kChunkElements, 1, kMaxChunks);
}

/// Deterministic sum of body(i) for i in [0, count): chunk partial sums added in order.
template <class Body>
double sum_parallel(int count, Body&& body) {
  const int chunks = assembly_chunks(count);
  double partial[kMaxChunks] = {0.0, 0.0, 0.0, 0.0};
#pragma omp parallel for schedule(static, 1) if (chunks > 1)
  for (int c = 0; c < chunks; ++c) {
    const int begin = static_cast<int>(static_cast<long long>(count) * c / chunks);
    const int end = static_cast<int>(static_cast<long long>(count) * (c + 1) / chunks);
    double s = 0.0;
    for (int i = begin; i < end; ++i) s += body(i);
    partial[c] = s;
  }
  double total = 0.0;
  for (int c = 0; c < chunks; ++c) total += partial[c];
  return total;
}

/// Runs body(element, local_grad) for element in [0, count) and returns the sum of the
/// values it returns; when grad != nullptr the contributions written into local_grad are
/// added into *grad (local_grad is *grad itself for the first chunk, a zeroed buffer of
/// the same shape for the others). body must only add into local_grad. Without a gradient
/// body receives a dummy empty matrix and must not touch it.
template <class Body>
double assemble_parallel(int count, Positions* grad, Body&& body) {
  const int chunks = assembly_chunks(count);
  double partial[kMaxChunks] = {0.0, 0.0, 0.0, 0.0};
  if (chunks == 1) {
    Positions dummy;
    Positions& g = grad ? *grad : dummy;
    double s = 0.0;
    for (int i = 0; i < count; ++i) s += body(i, g);
    return s;
  }
  std::vector<Positions> buffers(grad ? chunks - 1 : 0);
#pragma omp parallel for schedule(static, 1)
  for (int c = 0; c < chunks; ++c) {
    const int begin = static_cast<int>(static_cast<long long>(count) * c / chunks);
    const int end = static_cast<int>(static_cast<long long>(count) * (c + 1) / chunks);
    Positions dummy;
    Positions* g = &dummy;
    if (grad) {
      if (c == 0) {
        g = grad;
      } else {
        buffers[c - 1].setZero(3, grad->cols());
        g = &buffers[c - 1];
      }
    }
    double s = 0.0;
    for (int i = begin; i < end; ++i) s += body(i, *g);
    partial[c] = s;
  }
  if (grad) {
    const int n = static_cast<int>(grad->cols());
#pragma omp parallel for schedule(static)
    for (int v = 0; v < n; ++v)
      for (int c = 1; c < chunks; ++c) grad->col(v) += buffers[c - 1].col(v);
  }
  double total = 0.0;
  for (int c = 0; c < chunks; ++c) total += partial[c];
  return total;
}

}  // namespace rbc
