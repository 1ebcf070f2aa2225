// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Deterministic parallel assembly of per-element contributions: the elements
// are split into fixed-size chunks that depend on the element count only, never on the
// thread count; chunk 0 accumulates straight into the caller's gradient, every other chunk
// into its own zeroed buffer, and the chunks are then added in index order (per vertex).
// So the result is bit-identical with 1, 2 or more threads, and problems of one chunk
// (fewer than kChunkElements elements: the small meshes of parameter sweeps) run serially
// without allocating.
//
// Whether the chunks run on the threads is a separate decision, also a function of the count
// only (kParallelElements): below it they run in order on the calling thread, with the same
// chunks, so the same bits. A parallel region wakes the sleeping threads, ~50 us under
// OMP_WAIT_POLICY=passive on these machines (run.sh and test.sh set it), and a barrier costs
// ~30 us; the loops here do 5-20 ns of work per element.
#include <omp.h>

#include <algorithm>
#include <vector>

#include "core/mesh.hpp"

namespace rbc {

/// Elements per chunk, and the most chunks one assembly is split into (their buffers cost
/// one pass over 3N doubles each: more chunks than cores buy nothing on this machine).
inline constexpr int kChunkElements = 4096;
inline constexpr int kMaxChunks = 4;

/// Fewest elements for which a chunked loop runs on the threads. Measured on the 2-core
/// machine with OMP_WAIT_POLICY=passive (`rbc bench stretch --benchmark_filter=energy_gradient`):
/// at N = 1,962 vertices (5,880 edges) the 2-thread energy + gradient took 450-950 us against
/// ~400 us on one thread; from ~16,000 elements a chunk's work outweighs the wake-ups.
inline constexpr int kParallelElements = 16384;
/// The same for element kernels of ~100 ns and more (the continuum's membrane elements).
inline constexpr int kParallelHeavyElements = 4096;

/// Number of chunks for `count` elements (a function of the count only).
inline int assembly_chunks(int count) {
  return std::clamp((count + kChunkElements - 1) / kChunkElements, 1, kMaxChunks);
}

/// Whether the chunks of a loop over `count` elements run on the threads (from `parallel_from`
/// elements on).
inline bool parallel_chunks(int count, int parallel_from = kParallelElements) {
  return count >= parallel_from && assembly_chunks(count) > 1;
}

/// First element of chunk c of `chunks` over [0, count) (chunk c is [begin(c), begin(c + 1))).
inline int chunk_begin(int count, int chunks, int c) {
  return static_cast<int>(static_cast<long long>(count) * c / chunks);
}

/// Runs body(c, begin, end) for the chunks c of [0, count) (assembly_chunks(count) of them),
/// on the threads when parallel_chunks(count). body may write per-element outputs and
/// per-chunk partial results (indexed by c); the caller combines those in chunk order.
template <class Body>
void for_each_chunk(int count, Body&& body) {
  const int chunks = assembly_chunks(count);
  if (!parallel_chunks(count)) {
    for (int c = 0; c < chunks; ++c)
      body(c, chunk_begin(count, chunks, c), chunk_begin(count, chunks, c + 1));
    return;
  }
#pragma omp parallel for schedule(static, 1)
  for (int c = 0; c < chunks; ++c)
    body(c, chunk_begin(count, chunks, c), chunk_begin(count, chunks, c + 1));
}

/// Two chunked loops in one parallel region (one wake-up instead of two):
/// body_a(c, begin, end) over the chunks of [0, count_a), then body_b over those of
/// [0, count_b). With `Then::after` every chunk of the first loop has finished before the
/// second starts (a barrier); with `Then::independent` the loops must not read each other's
/// output. On the calling thread unless either loop is parallel_chunks; the chunks, so the
/// bits, are those of two for_each_chunk calls.
enum class Then { after, independent };
template <class BodyA, class BodyB>
void for_each_chunk_pair(int count_a, BodyA&& body_a, int count_b, BodyB&& body_b, Then then) {
  const int chunks_a = assembly_chunks(count_a), chunks_b = assembly_chunks(count_b);
  if (!parallel_chunks(count_a) && !parallel_chunks(count_b)) {
    for (int c = 0; c < chunks_a; ++c)
      body_a(c, chunk_begin(count_a, chunks_a, c), chunk_begin(count_a, chunks_a, c + 1));
    for (int c = 0; c < chunks_b; ++c)
      body_b(c, chunk_begin(count_b, chunks_b, c), chunk_begin(count_b, chunks_b, c + 1));
    return;
  }
#pragma omp parallel
  {
    if (then == Then::after) {
#pragma omp for schedule(static, 1)
      for (int c = 0; c < chunks_a; ++c)
        body_a(c, chunk_begin(count_a, chunks_a, c), chunk_begin(count_a, chunks_a, c + 1));
    } else {
#pragma omp for schedule(static, 1) nowait
      for (int c = 0; c < chunks_a; ++c)
        body_a(c, chunk_begin(count_a, chunks_a, c), chunk_begin(count_a, chunks_a, c + 1));
    }
#pragma omp for schedule(static, 1)
    for (int c = 0; c < chunks_b; ++c)
      body_b(c, chunk_begin(count_b, chunks_b, c), chunk_begin(count_b, chunks_b, c + 1));
  }
}

/// Deterministic sum of body(i) for i in [0, count): chunk partial sums added in order.
template <class Body>
double sum_parallel(int count, Body&& body) {
  double partial[kMaxChunks] = {0.0, 0.0, 0.0, 0.0};
  for_each_chunk(count, [&](int c, int begin, int end) {
    double s = 0.0;
    for (int i = begin; i < end; ++i) s += body(i);
    partial[c] = s;
  });
  double total = 0.0;
  for (int c = 0; c < assembly_chunks(count); ++c) total += partial[c];
  return total;
}

/// Runs body(c, local_grad) for the chunks c of a loop over `count` elements
/// (assembly_chunks(count) of them) and adds the contributions written into local_grad into
/// *grad deterministically (local_grad is *grad itself for c = 0, a zeroed buffer of the same
/// shape for the others, added in chunk order). On the threads when
/// parallel_chunks(count, parallel_from). Without a gradient body receives a dummy empty matrix
/// and must not touch it.
template <class Body>
void assemble_chunks(int count, Positions* grad, Body&& body,
                     int parallel_from = kParallelElements) {
  const int chunks = assembly_chunks(count);
  if (chunks == 1) {
    Positions dummy;
    body(0, grad ? *grad : dummy);
    return;
  }
  std::vector<Positions> buffers(grad ? chunks - 1 : 0);
  const int n = grad ? static_cast<int>(grad->cols()) : 0;
  auto run_chunk = [&](int c) {
    Positions dummy;
    Positions* g = &dummy;
    if (grad) {
      if (c == 0) {
        g = grad;
      } else {
        buffers[c - 1].setZero(3, n);
        g = &buffers[c - 1];
      }
    }
    body(c, *g);
  };
  auto reduce = [&](int v) {
    for (int c = 1; c < chunks; ++c) grad->col(v) += buffers[c - 1].col(v);
  };
  if (!parallel_chunks(count, parallel_from)) {
    for (int c = 0; c < chunks; ++c) run_chunk(c);
    for (int v = 0; v < n; ++v) reduce(v);
    return;
  }
  // One parallel region: the chunks, a barrier, then the per-vertex reduction.
#pragma omp parallel
  {
#pragma omp for schedule(static, 1)
    for (int c = 0; c < chunks; ++c) run_chunk(c);
#pragma omp for schedule(static)
    for (int v = 0; v < n; ++v) reduce(v);
  }
}

/// Runs body(element, local_grad) for element in [0, count) and returns the sum of the
/// values it returns; when grad != nullptr the contributions written into local_grad are
/// added into *grad (local_grad is *grad itself for the first chunk, a zeroed buffer of
/// the same shape for the others). body must only add into local_grad. Without a gradient
/// body receives a dummy empty matrix and must not touch it. On the threads from
/// `parallel_from` elements on (kParallelHeavyElements for costly element kernels).
template <class Body>
double assemble_parallel(int count, Positions* grad, Body&& body,
                         int parallel_from = kParallelElements) {
  const int chunks = assembly_chunks(count);
  double partial[kMaxChunks] = {0.0, 0.0, 0.0, 0.0};
  assemble_chunks(
      count, grad,
      [&](int c, Positions& g) {
        double s = 0.0;
        const int end = chunk_begin(count, chunks, c + 1);
        for (int i = chunk_begin(count, chunks, c); i < end; ++i) s += body(i, g);
        partial[c] = s;
      },
      parallel_from);
  double total = 0.0;
  for (int c = 0; c < chunks; ++c) total += partial[c];
  return total;
}

}  // namespace rbc
