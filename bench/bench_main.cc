// one benchmark executable for every bench/*.cc
#include <benchmark/benchmark.h>

BENCHMARK_MAIN();
