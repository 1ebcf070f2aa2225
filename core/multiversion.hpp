// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Function multiversioning for the hot element loops: RBC_HOT_CLONES compiles a
// function twice, for the portable x86-64 baseline and for x86-64-v3 (AVX2, FMA, BMI2), and
// the dynamic loader picks the best one for the machine once (GCC target_clones, an ifunc).
// The build stays portable: no -march=native. Fused multiply-add contraction is off for the
// whole project (CMakeLists.txt, -ffp-contract=off), so both versions carry out the same IEEE
// operations in the same order and give the same bits; the x86-64-v3 one wins by its
// three-operand (VEX) instructions, ~20 % fewer instructions in the geometry and assembly
// loops (callgrind), 8-10 % less time on one thread (discrete energy + gradient, N = 492 and
// 27,042). Measure before adding a function: the continuum element Hessians (9 x 9 and
// 12 x 12 blocks) ran 10-15 % slower as clones, so they are not. Off for clang (fuzz build) and the
// sanitizer build, where ifuncs are not worth the trouble.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && \
    !defined(__SANITIZE_ADDRESS__) && defined(__linux__)
#define RBC_HOT_CLONES [[gnu::target_clones("arch=x86-64-v3", "default")]]
#else
#define RBC_HOT_CLONES
#endif
