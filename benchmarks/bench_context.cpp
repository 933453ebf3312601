// SPDX-License-Identifier: MIT
// Records how this binary was built as Google Benchmark context: printed in the console header of every
// run ("aaf_build_flags: GNU 12.2.0 Release: -O3 -DNDEBUG -O3 -march=native") and written to the JSON
// output's "context". Header-only code runs at the speed of the flags it is compiled with, so every figure
// must be read together with this line (docs/BENCHMARKS.md).

#include <benchmark/benchmark.h>

#include <string>
#include <thread>

namespace {

[[maybe_unused]] const bool context_recorded = [] {
#ifdef AAF_BUILD_FLAGS
    benchmark::AddCustomContext("aaf_build_flags", AAF_BUILD_FLAGS);
#else
    benchmark::AddCustomContext("aaf_build_flags", "unknown (AAF_BUILD_FLAGS not defined)");
#endif
    benchmark::AddCustomContext("aaf_hardware_threads", std::to_string(std::thread::hardware_concurrency()));
    return true;
}();

}  // namespace
