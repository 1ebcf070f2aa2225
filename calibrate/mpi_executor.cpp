// SPDX-License-Identifier: GPL-3.0-or-later
#include "calibrate/mpi_executor.hpp"

#include <mpi.h>
#include <omp.h>

#include <cstdlib>
#include <deque>
#include <stdexcept>
#include <string>
#include <vector>

namespace rbc {

namespace {
constexpr int kTagTask = 1, kTagResult = 2, kTagStop = 3;
/// Chains in flight per worker.
constexpr int kDepth = 2;

void check(int rc, const char* what) {
  if (rc != MPI_SUCCESS) throw std::runtime_error(std::string("MPI call failed: ") + what);
}

// Messages are arrays of doubles; integers are below 2^53, the 64-bit seed goes in halves.
std::vector<double> pack_task(const StageSetup& s, const ChainTask& t) {
  const int d = static_cast<int>(t.theta.size());
  std::vector<double> b = {double(s.stage),
                           s.beta,
                           double(s.chain_length),
                           double(s.seed >> 32),
                           double(s.seed & 0xffffffffu),
                           double(d)};
  for (int j = 0; j < d; ++j)
    for (int i = 0; i < d; ++i) b.push_back(s.chain_length ? s.proposal_chol(i, j) : 0.0);
  b.push_back(double(t.index));
  b.push_back(t.log_likelihood);
  b.insert(b.end(), t.theta.begin(), t.theta.end());
  b.push_back(double(t.state.size()));
  b.insert(b.end(), t.state.begin(), t.state.end());
  return b;
}

void unpack_task(const std::vector<double>& b, StageSetup& s, ChainTask& t) {
  size_t p = 0;
  s.stage = int(b[p++]);
  s.beta = b[p++];
  s.chain_length = int(b[p++]);
  const auto hi = static_cast<std::uint64_t>(b[p++]), lo = static_cast<std::uint64_t>(b[p++]);
  s.seed = (hi << 32) | lo;
  const int d = int(b[p++]);
  s.proposal_chol.resize(d, d);
  for (int j = 0; j < d; ++j)
    for (int i = 0; i < d; ++i) s.proposal_chol(i, j) = b[p++];
  t = ChainTask{};
  t.index = int(b[p++]);
  t.log_likelihood = b[p++];
  t.theta.assign(b.begin() + p, b.begin() + p + d);
  p += d;
  const size_t ns = size_t(b[p++]);
  t.state.assign(b.begin() + p, b.begin() + p + ns);
}

std::vector<double> pack_result(const ChainTask& t) {
  std::vector<double> b = {double(t.index),         t.log_likelihood,
                           double(t.proposed),      double(t.accepted),
                           double(t.counts.runs),   double(t.counts.retried),
                           double(t.counts.failed), double(t.counts.symmetry_broken),
                           double(t.theta.size())};
  b.insert(b.end(), t.theta.begin(), t.theta.end());
  b.push_back(double(t.state.size()));
  b.insert(b.end(), t.state.begin(), t.state.end());
  return b;
}

void unpack_result(const std::vector<double>& b, std::vector<ChainTask>& tasks) {
  size_t p = 0;
  ChainTask& t = tasks.at(size_t(b[p++]));
  t.log_likelihood = b[p++];
  t.proposed = int(b[p++]);
  t.accepted = int(b[p++]);
  t.counts.runs = static_cast<long long>(b[p++]);
  t.counts.retried = static_cast<long long>(b[p++]);
  t.counts.failed = static_cast<long long>(b[p++]);
  t.counts.symmetry_broken = static_cast<long long>(b[p++]);
  const size_t d = size_t(b[p++]);
  t.theta.assign(b.begin() + p, b.begin() + p + d);
  p += d;
  const size_t ns = size_t(b[p++]);
  t.state.assign(b.begin() + p, b.begin() + p + ns);
}

std::vector<double> receive(int source, int tag, MPI_Status& st) {
  check(MPI_Probe(source, tag, MPI_COMM_WORLD, &st), "MPI_Probe");
  int count = 0;
  MPI_Get_count(&st, MPI_DOUBLE, &count);
  std::vector<double> b(count);
  check(MPI_Recv(b.data(), count, MPI_DOUBLE, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE),
        "MPI_Recv");
  return b;
}

/// Sets OpenMP's thread count of the calling thread for a scope (inner regions at 1).
struct SingleThreadScope {
  int saved = omp_get_max_threads();
  SingleThreadScope() { omp_set_num_threads(1); }
  ~SingleThreadScope() { omp_set_num_threads(saved); }
};

struct InFlight {
  std::vector<double> buffer;
  MPI_Request request = MPI_REQUEST_NULL;
};
}  // namespace

bool launched_by_mpirun() {
  return std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMI_SIZE") || std::getenv("PMIX_RANK");
}

MpiSession::MpiSession() {
  setenv("OMPI_MCA_btl_vader_single_copy_mechanism", "none", 0);
  setenv("OMPI_MCA_mpi_yield_when_idle", "1", 0);
  check(MPI_Init(nullptr, nullptr), "MPI_Init");
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

MpiSession::~MpiSession() {
  MPI_Finalize();
}

void MpiSession::abort(int code) const {
  MPI_Abort(MPI_COMM_WORLD, code);
  std::exit(code);
}

Executor mpi_master_executor(const PriorBox& prior, const Likelihood& likelihood,
                             CancelCheck cancel) {
  return [&prior, &likelihood, cancel](const StageSetup& setup, std::vector<ChainTask>& tasks) {
    int size = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    const SingleThreadScope one_thread;
    const int n = static_cast<int>(tasks.size());
    int next = 0, done = 0;
    std::vector<std::deque<InFlight>> inflight(size);
    const auto send = [&](int worker) {
      InFlight f;
      f.buffer = pack_task(setup, tasks[next++]);
      inflight[worker].push_back(std::move(f));
      InFlight& g = inflight[worker].back();
      check(MPI_Isend(g.buffer.data(), static_cast<int>(g.buffer.size()), MPI_DOUBLE, worker,
                      kTagTask, MPI_COMM_WORLD, &g.request),
            "MPI_Isend");
    };
    for (int rep = 0; rep < kDepth; ++rep)
      for (int w = 1; w < size && next < n; ++w) send(w);
    bool cancelled = false;
    // Cancelled: no further chain starts; the ones handed out are collected (done == next).
    while (done < (cancelled ? next : n)) {
      if (!cancelled && cancel && cancel()) {
        cancelled = true;
        continue;
      }
      int flag = 0;
      MPI_Status st;
      check(MPI_Iprobe(MPI_ANY_SOURCE, kTagResult, MPI_COMM_WORLD, &flag, &st), "MPI_Iprobe");
      if (flag || next >= n || cancelled) {
        const std::vector<double> b =
            receive(flag ? st.MPI_SOURCE : MPI_ANY_SOURCE, kTagResult, st);
        unpack_result(b, tasks);
        ++done;
        const int w = st.MPI_SOURCE;
        MPI_Wait(&inflight[w].front().request, MPI_STATUS_IGNORE);  // its oldest task
        inflight[w].pop_front();
        if (next < n && !cancelled) send(w);
      } else {
        run_chain(setup, prior, likelihood, tasks[next++]);  // the master computes too
        ++done;
      }
    }
    if (cancelled) throw Cancelled();
  };
}

void mpi_stop_workers() {
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  for (int w = 1; w < size; ++w) MPI_Send(nullptr, 0, MPI_DOUBLE, w, kTagStop, MPI_COMM_WORLD);
}

void mpi_worker_loop(const PriorBox& prior, const Likelihood& likelihood) {
  const SingleThreadScope one_thread;
  InFlight pending;  // the last result, sent while the next chain runs
  while (true) {
    MPI_Status st;
    check(MPI_Probe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &st), "MPI_Probe");
    if (st.MPI_TAG == kTagStop) {
      MPI_Recv(nullptr, 0, MPI_DOUBLE, 0, kTagStop, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      break;
    }
    const std::vector<double> b = receive(0, kTagTask, st);
    StageSetup setup;
    ChainTask task;
    unpack_task(b, setup, task);
    run_chain(setup, prior, likelihood, task);
    MPI_Wait(&pending.request, MPI_STATUS_IGNORE);
    pending.buffer = pack_result(task);
    check(MPI_Isend(pending.buffer.data(), static_cast<int>(pending.buffer.size()), MPI_DOUBLE, 0,
                    kTagResult, MPI_COMM_WORLD, &pending.request),
          "MPI_Isend");
  }
  MPI_Wait(&pending.request, MPI_STATUS_IGNORE);
}

}  // namespace rbc
