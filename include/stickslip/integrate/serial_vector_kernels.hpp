#pragma once
// The serial vector's per-entry kernels, compiled with the project: ARKODE
// and CVODE do all their per-entry work through them (why: the .cpp).

#include <nvector/nvector_serial.h>

namespace stickslip {

// Replaces the operations of serial vector `v` (and of its future clones)
// with this file's kernels, each computing what SUNDIALS' own computes, bit
// for bit (the WRMS norm: to rounding).
void use_compiled_kernels(N_Vector v);

}  // namespace stickslip
