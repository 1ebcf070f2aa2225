// SPDX-License-Identifier: GPL-3.0-or-later
// Deterministic reductions: core/parallel.hpp splits elements into chunks that
// depend on the element count only, so the energy and every gradient bit are the same with
// 1, 2 and 3 OpenMP threads. The network (N ~ 17,000: ~51,000 links, ~34,000 faces) is large
// enough for several chunks run on the threads (parallel_chunks: edges, faces and vertices),
// so the parallel multi-chunk path is the one tested; a check that the plain serial sum in
// another order differs in the last bits shows the test could fail.
#include <gtest/gtest.h>
#include <omp.h>

#include "core/parallel.hpp"
#include "core/rest_shape.hpp"
#include "discrete/network.hpp"
#include "fixtures.hpp"

namespace rbc {
namespace {

struct ThreadCount {
  explicit ThreadCount(int n) : saved(omp_get_max_threads()) { omp_set_num_threads(n); }
  ~ThreadCount() { omp_set_num_threads(saved); }
  int saved;
};

TEST(DeterministicSums, NetworkEnergyAndGradientBitIdenticalWithOneTwoThreeThreads) {
  RestShapeOptions o;
  o.target_vertices = 17000;
  const Network net = build_network(make_rest_shape(o), NetworkParameters{});
  ASSERT_TRUE(parallel_chunks(net.topo.num_edges()));
  ASSERT_TRUE(parallel_chunks(net.topo.num_faces()));
  ASSERT_TRUE(parallel_chunks(net.topo.num_vertices));
  Positions x = net.rest;
  testing::perturb(x, 0.01, 3);
  LoadState load;
  load.force_pN = 88.0;
  load.multipliers = {2.0, -1.0};
  double e[3];
  Positions g[3];
  for (int t = 1; t <= 3; ++t) {
    const ThreadCount threads(t);
    e[t - 1] = network_energy(net, x, load, &g[t - 1]);
  }
  for (int t = 1; t < 3; ++t) {
    EXPECT_EQ(e[t], e[0]) << t + 1 << " threads";
    EXPECT_TRUE((g[t].array() == g[0].array()).all()) << t + 1 << " threads";
  }
}

TEST(DeterministicSums, SumParallelIsTheChunkedSumWhateverTheThreads) {
  // Terms of very different magnitudes: the order of summation shows in the last bits.
  const int n = 20000;
  auto term = [](int i) { return (i % 7 == 0 ? 1e8 : 1.0) * std::sin(0.37 * i) + 1e-3 * i; };
  double by_threads[3];
  for (int t = 1; t <= 3; ++t) {
    const ThreadCount threads(t);
    by_threads[t - 1] = sum_parallel(n, term);
  }
  EXPECT_EQ(by_threads[1], by_threads[0]);
  EXPECT_EQ(by_threads[2], by_threads[0]);
  double backwards = 0.0;
  for (int i = n - 1; i >= 0; --i) backwards += term(i);
  EXPECT_NEAR(backwards, by_threads[0], 1e-6 * std::abs(backwards));
  EXPECT_NE(backwards, by_threads[0]) << "the terms do not probe the summation order";
}

}  // namespace
}  // namespace rbc
