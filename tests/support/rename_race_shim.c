// SPDX-License-Identifier: GPL-3.0-or-later
// Another process's move at the worst moment, on demand: loaded with LD_PRELOAD, this library
// makes rename(2) onto the path RBC_RACE_DIRECTORY_AT (compared as given) first put an empty
// directory there, removing a file that stands there, and only then rename. That is what a
// user or script replacing the target between a writer's checks and its rename looks like; the
// timing that is rare in a live race is here every time. Other renames are untouched.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int rename(const char* from, const char* to) {
  static int (*real_rename)(const char*, const char*) = NULL;
  if (!real_rename) real_rename = (int (*)(const char*, const char*))dlsym(RTLD_NEXT, "rename");
  const char* at = getenv("RBC_RACE_DIRECTORY_AT");
  if (at && *at && to && strcmp(to, at) == 0) {
    (void)unlink(to);
    (void)mkdir(to, 0777);
  }
  return real_rename(from, to);
}
