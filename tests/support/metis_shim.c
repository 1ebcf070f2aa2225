// SPDX-License-Identifier: GPL-3.0-or-later
// Test-only LD_PRELOAD library for tests/app/test_signals.cpp: a signal at a chosen point inside
// the sparse analysis's METIS ordering, with no hook in the executable. CHOLMOD (a shared
// library) calls METIS_NodeND through the dynamic linker, so this definition is the one it
// reaches; it forwards to libmetis's (dlsym RTLD_NEXT). RBC_METIS_SHIM = MODE:N acts on the N-th
// METIS_NodeND call of the process (N >= 1):
//   term:N          kill(getpid(), SIGTERM) from inside the ordering, at METIS's first call of
//                   rand()/srand() (its random state, drawn while its own SIGTERM handler is
//                   installed): a user's SIGTERM arriving during an ordering;
//   int:N           the same with SIGINT;
//   error:N         raise(SIGTERM) at the same point, as METIS's error path (GKlib's gk_errexit)
//                   does, and the ordering goes on;
//   error-return:N  raise(SIGTERM), then METIS_ERROR without an ordering (the permutation left
//                   as it was), as METIS returns once its handler has caught the error.
// With RBC_METIS_SHIM_LOG set, each call writes "metis_shim: call N start T" and (unless a mode
// acts on it) "metis_shim: call N end T" to stderr, T in seconds of CLOCK_MONOTONIC.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

enum { kMetisError = -4 };  // METIS_ERROR (metis.h)
enum Mode { kNone, kTerm, kInt, kError, kErrorReturn };

typedef int (*NodeNd)(void*, void*, void*, void*, void*, void*, void*);
typedef int (*Rand)(void);
typedef void (*Srand)(unsigned);

static atomic_int calls;
static _Thread_local int armed;  // the chosen call is running on this thread, not yet fired
static _Thread_local enum Mode armed_mode;

/// CLOCK_MONOTONIC in seconds: comparable with the times of another process on the machine.
static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static enum Mode parse(long* n) {
  const char* v = getenv("RBC_METIS_SHIM");
  if (!v) return kNone;
  const char* colon = strchr(v, ':');
  *n = colon ? strtol(colon + 1, NULL, 10) : 1;
  const size_t len = colon ? (size_t)(colon - v) : strlen(v);
  if (len == 4 && strncmp(v, "term", 4) == 0) return kTerm;
  if (len == 3 && strncmp(v, "int", 3) == 0) return kInt;
  if (len == 5 && strncmp(v, "error", 5) == 0) return kError;
  if (len == 12 && strncmp(v, "error-return", 12) == 0) return kErrorReturn;
  return kNone;
}

static void fire(void) {
  if (!armed) return;
  armed = 0;
  if (armed_mode == kTerm || armed_mode == kInt)
    kill(getpid(), armed_mode == kTerm ? SIGTERM : SIGINT);
  else
    raise(SIGTERM);
}

int rand(void) {
  fire();
  return ((Rand)dlsym(RTLD_NEXT, "rand"))();
}

void srand(unsigned seed) {
  fire();
  ((Srand)dlsym(RTLD_NEXT, "srand"))(seed);
}

int METIS_NodeND(void* nvtxs, void* xadj, void* adjncy, void* vwgt, void* options, void* perm,
                 void* iperm) {
  const int call = atomic_fetch_add(&calls, 1) + 1;
  const int log = getenv("RBC_METIS_SHIM_LOG") != NULL;
  if (log) fprintf(stderr, "metis_shim: call %d start %.6f\n", call, now_s());
  long n = 0;
  const enum Mode mode = parse(&n);
  const NodeNd real = (NodeNd)dlsym(RTLD_NEXT, "METIS_NodeND");
  if (mode == kNone || call != n) {
    const int status = real(nvtxs, xadj, adjncy, vwgt, options, perm, iperm);
    if (log) fprintf(stderr, "metis_shim: call %d end %.6f\n", call, now_s());
    return status;
  }
  if (mode == kErrorReturn) {
    raise(SIGTERM);
    return kMetisError;
  }
  armed = 1;
  armed_mode = mode;
  const int status = real(nvtxs, xadj, adjncy, vwgt, options, perm, iperm);
  if (armed) {
    armed = 0;
    fprintf(stderr, "metis_shim: METIS_NodeND drew no random number; nothing sent\n");
  }
  return status;
}
