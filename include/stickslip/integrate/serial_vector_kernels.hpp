#pragma once
// The serial vector's per-entry kernels, compiled with the project: ARKODE
// and CVODE do all their per-entry work through them (why: the .cpp).

#include <nvector/nvector_serial.h>

namespace stickslip {

// Replaces the operations of serial vector `v` (and of its future clones)
// with this file's kernels, each computing what SUNDIALS' own computes, bit
// for bit (the WRMS norm: to rounding).
void use_compiled_kernels(N_Vector v);

// While alive, the kernels called from this thread run their per-entry
// (elementwise) loops on `threads` OpenMP threads, over fixed blocks of
// entries, for vectors long enough to pay for it: each entry is computed as
// on one thread, so results do not change. Reductions (norms, dot products)
// stay serial: their order of summation is SUNDIALS'.
class ScopedKernelThreads {
 public:
  explicit ScopedKernelThreads(int threads);
  ~ScopedKernelThreads();
  ScopedKernelThreads(const ScopedKernelThreads&) = delete;
  ScopedKernelThreads& operator=(const ScopedKernelThreads&) = delete;

 private:
  int previous_;
};

}  // namespace stickslip
