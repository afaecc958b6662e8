/* LD_PRELOAD shim for the proxy benchmark: makes std::thread::hardware_concurrency() return
 * $TELLUS_BENCH_THREADS, so that `tellus serve` (whose HTTP server runs one event-loop thread per
 * core when no thread count is configured) can be measured with 1, 2, 4... loop threads without a
 * rebuild. Nothing else in tellus asks for the core count. Built by bench/proxy/run.sh when
 * HTTP_THREADS is set:  cc -shared -fPIC -O2 -o threads_shim.so threads_shim.c */
#include <stdlib.h>

/* std::thread::hardware_concurrency() (libstdc++, GLIBCXX_3.4.17), a static member function. */
unsigned int _ZNSt6thread20hardware_concurrencyEv(void) {
  const char* s = getenv("TELLUS_BENCH_THREADS");
  const long n = s ? strtol(s, NULL, 10) : 0;
  return n > 0 ? (unsigned int)n : 1u;
}
