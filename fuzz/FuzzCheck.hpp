#pragma once
// The invariant check of the fuzz targets: a violated property is a crash that libFuzzer records
// (with the input as crash-<sha1>), like a sanitizer report. Active in every build type (no
// NDEBUG dependence, unlike assert).

#include <cstdio>

#define TELLUS_FUZZ_CHECK(cond)                                                                    \
  do {                                                                                             \
    if (!(cond)) {                                                                                 \
      std::fprintf(stderr, "%s:%d: fuzz invariant violated: %s\n", __FILE__, __LINE__, #cond);     \
      __builtin_trap();                                                                            \
    }                                                                                              \
  } while (false)
