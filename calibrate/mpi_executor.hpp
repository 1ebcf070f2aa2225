// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// TMCMC over MPI ranks (OpenMPI): a master-worker pool with dynamic scheduling in which the
// master computes too. `mpirun -np K rbc infer ...` runs the same command on K ranks; every
// rank builds the same InferenceProblem; rank 0 runs the sampler and hands chains to
// whichever rank is free (two in flight per worker, so a worker never waits for the master
// while the master computes a chain of its own); workers run run_chain() on what they get
// and send the chain's end state back. Results are stored by task index, so the posterior
// does not depend on which rank ran which chain (calibrate/tmcmc.hpp, Determinism).
//
// MPI is initialised only by MpiSession, only when the process was started by mpirun
// (OMPI_COMM_WORLD_SIZE, PMI_SIZE or PMIX_RANK in the environment), so no other command of
// `rbc` touches MPI. Before MPI_Init it sets, unless already set, the OpenMPI parameters a
// container needs: OMPI_MCA_btl_vader_single_copy_mechanism=none (no CMA/ptrace between
// ranks: without it the shared-memory transport fails or warns in Docker) and
// OMPI_MCA_mpi_yield_when_idle=1 (waiting ranks yield the core instead of spinning, which
// matters on a machine with fewer cores than ranks).
// Each rank runs one chain at a time with its OpenMP inner regions at one thread.
#include "calibrate/infer.hpp"
#include "calibrate/tmcmc.hpp"

namespace rbc {

/// True when the environment says this process was launched by mpirun/mpiexec.
bool launched_by_mpirun();

/// RAII MPI_Init / MPI_Finalize (only construct it when launched_by_mpirun()).
class MpiSession {
 public:
  MpiSession();
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }
  /// Aborts every rank with this exit code (after a fatal error on one rank).
  [[noreturn]] void abort(int code) const;

 private:
  int rank_ = 0, size_ = 1;
};

/// The master's executor (rank 0). Call mpi_stop_workers() when done (also after an error).
/// With `cancel`, polled before each chain is handed out: once it is true no further chain
/// starts, the chains in flight are collected and the executor throws rbc::Cancelled.
Executor mpi_master_executor(const PriorBox& prior, const Likelihood& likelihood,
                             CancelCheck cancel = {});
/// Releases every worker from mpi_worker_loop (rank 0; idempotent).
void mpi_stop_workers();
/// A worker's loop (ranks > 0): serves chains until the master stops it.
void mpi_worker_loop(const PriorBox& prior, const Likelihood& likelihood);

}  // namespace rbc
