// How OpenMP's idle threads wait (docs/PIPELINE.md, "Threads").
#pragma once

namespace orpe {

/// Call first thing in main(argv). GCC's OpenMP runtime reads OMP_WAIT_POLICY once, when it loads
/// (before main); unset, its idle threads spin for a while after every parallel loop, which on a
/// 2-core machine takes the core from the stages' serial code, their other threads and other
/// processes. When neither OMP_WAIT_POLICY nor GOMP_SPINCOUNT is set, this sets
/// OMP_WAIT_POLICY=passive and executes the program again (/proc/self/exe, same argv; once: the new
/// process finds it set). It does nothing under valgrind (its client would run natively) and
/// returns normally when the program cannot be executed again (then the runtime's default stays).
void prefer_passive_openmp_waits(char** argv);

}  // namespace orpe
