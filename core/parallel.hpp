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

/// First element of chunk c of `chunks` over [0, count) (chunk c is [begin(c), begin(c + 1))).
inline int chunk_begin(int count, int chunks, int c) {
  return static_cast<int>(static_cast<long long>(count) * c / chunks);
}

/// Runs body(c, begin, end) for the chunks c of [0, count) (assembly_chunks(count) of them),
/// in parallel when there is more than one. body may write per-element outputs and per-chunk
/// partial results (indexed by c); the caller combines those in chunk order.
template <class Body>
void for_each_chunk(int count, Body&& body) {
  const int chunks = assembly_chunks(count);
  if (chunks == 1) {
    body(0, 0, count);
    return;
  }
#pragma omp parallel for schedule(static, 1)
  for (int c = 0; c < chunks; ++c)
    body(c, chunk_begin(count, chunks, c), chunk_begin(count, chunks, c + 1));
}

/// Two chunked loops in one parallel region (each thread wake-up costs ~50 us under
/// OMP_WAIT_POLICY=passive, more than a chunk's work at mid sizes): body_a(c, begin, end) over
/// the chunks of [0, count_a), then body_b over those of [0, count_b). With `Then::after` every
/// chunk of the first loop has finished before the second starts (a barrier); with
/// `Then::independent` the loops must not read each other's output. Serial when both loops are
/// one chunk; the chunks, so the bits, are those of two for_each_chunk calls.
enum class Then { after, independent };
template <class BodyA, class BodyB>
void for_each_chunk_pair(int count_a, BodyA&& body_a, int count_b, BodyB&& body_b, Then then) {
  const int chunks_a = assembly_chunks(count_a), chunks_b = assembly_chunks(count_b);
  if (chunks_a == 1 && chunks_b == 1) {
    body_a(0, 0, count_a);
    body_b(0, 0, count_b);
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

/// Runs body(c, local_grad) for c in [0, chunks) and adds the contributions written into
/// local_grad into *grad deterministically (local_grad is *grad itself for c = 0, a zeroed
/// buffer of the same shape for the others, added in chunk order). chunks must be a function
/// of the problem size only (assembly_chunks). Without a gradient body receives a dummy
/// empty matrix and must not touch it.
template <class Body>
void assemble_chunks(int chunks, Positions* grad, Body&& body) {
  if (chunks == 1) {
    Positions dummy;
    body(0, grad ? *grad : dummy);
    return;
  }
  std::vector<Positions> buffers(grad ? chunks - 1 : 0);
  const int n = grad ? static_cast<int>(grad->cols()) : 0;
  // One parallel region: the chunks, a barrier, then the per-vertex reduction.
#pragma omp parallel
  {
#pragma omp for schedule(static, 1)
    for (int c = 0; c < chunks; ++c) {
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
    }
#pragma omp for schedule(static)
    for (int v = 0; v < n; ++v)
      for (int c = 1; c < chunks; ++c) grad->col(v) += buffers[c - 1].col(v);
  }
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
  assemble_chunks(chunks, grad, [&](int c, Positions& g) {
    double s = 0.0;
    const int end = chunk_begin(count, chunks, c + 1);
    for (int i = chunk_begin(count, chunks, c); i < end; ++i) s += body(i, g);
    partial[c] = s;
  });
  double total = 0.0;
  for (int c = 0; c < chunks; ++c) total += partial[c];
  return total;
}

}  // namespace rbc
