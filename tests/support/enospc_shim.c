// SPDX-License-Identifier: GPL-3.0-or-later
// A full disk on demand, without root: loaded with LD_PRELOAD, this library lets a process
// write RBC_ENOSPC_AFTER bytes in total (default 0) to files under the directory
// RBC_ENOSPC_DIR (an absolute, canonical path); after that, write, pwrite, writev and fsync
// on those files fail with ENOSPC, as on a file system with no space left. A write that
// crosses the limit is cut short there (a partial write, as the kernel does). Other files
// (stdout, stderr, anything outside the directory) are untouched. Writes the C library makes
// internally (stdio) do not pass through here; the project's writers and HDF5 call these
// functions directly.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <limits.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/uio.h>
#include <unistd.h>

static atomic_llong g_used = 0;

/// Whether fd is a file under RBC_ENOSPC_DIR.
static int watched(int fd) {
  const char* dir = getenv("RBC_ENOSPC_DIR");
  if (!dir || !*dir) return 0;
  char link[64], target[PATH_MAX];
  snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  const ssize_t n = readlink(link, target, sizeof target - 1);
  if (n <= 0) return 0;
  target[n] = '\0';
  const size_t len = strlen(dir);
  return strncmp(target, dir, len) == 0 && (target[len] == '/' || target[len] == '\0');
}

static long long limit_bytes(void) {
  const char* s = getenv("RBC_ENOSPC_AFTER");
  return s ? atoll(s) : 0;
}

/// How many of `count` bytes may still be written (0: the disk is full).
static size_t allowance(size_t count) {
  const long long left = limit_bytes() - atomic_load(&g_used);
  if (left <= 0) return 0;
  return (unsigned long long)left < count ? (size_t)left : count;
}

#define NEXT(name, type) ((type)dlsym(RTLD_NEXT, name))

ssize_t write(int fd, const void* buf, size_t count) {
  ssize_t (*next)(int, const void*, size_t) = NEXT("write", ssize_t(*)(int, const void*, size_t));
  if (count == 0 || !watched(fd)) return next(fd, buf, count);
  const size_t n = allowance(count);
  if (n == 0) {
    errno = ENOSPC;
    return -1;
  }
  const ssize_t done = next(fd, buf, n);
  if (done > 0) atomic_fetch_add(&g_used, done);
  return done;
}

ssize_t pwrite(int fd, const void* buf, size_t count, off_t offset) {
  ssize_t (*next)(int, const void*, size_t, off_t) =
      NEXT("pwrite", ssize_t(*)(int, const void*, size_t, off_t));
  if (count == 0 || !watched(fd)) return next(fd, buf, count, offset);
  const size_t n = allowance(count);
  if (n == 0) {
    errno = ENOSPC;
    return -1;
  }
  const ssize_t done = next(fd, buf, n, offset);
  if (done > 0) atomic_fetch_add(&g_used, done);
  return done;
}

ssize_t pwrite64(int fd, const void* buf, size_t count, off_t offset) {
  return pwrite(fd, buf, count, offset);
}

ssize_t writev(int fd, const struct iovec* iov, int iovcnt) {
  ssize_t (*next)(int, const struct iovec*, int) =
      NEXT("writev", ssize_t(*)(int, const struct iovec*, int));
  if (!watched(fd)) return next(fd, iov, iovcnt);
  ssize_t total = 0;
  for (int k = 0; k < iovcnt; ++k) {
    if (iov[k].iov_len == 0) continue;
    const ssize_t n = write(fd, iov[k].iov_base, iov[k].iov_len);
    if (n < 0) return total > 0 ? total : -1;
    total += n;
    if ((size_t)n < iov[k].iov_len) break;
  }
  return total;
}

static int sync_common(const char* name, int fd) {
  int (*next)(int) = NEXT(name, int (*)(int));
  if (watched(fd) && limit_bytes() - atomic_load(&g_used) <= 0) {
    errno = ENOSPC;
    return -1;
  }
  return next(fd);
}

int fsync(int fd) {
  return sync_common("fsync", fd);
}
int fdatasync(int fd) {
  return sync_common("fdatasync", fd);
}
