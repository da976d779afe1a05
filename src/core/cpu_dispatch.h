#pragma once

// Marks a per-pixel loop to be compiled twice, for AVX2 and for baseline x86-64, the better one
// picked when the library loads (GCC/Clang function multi-versioning, an ifunc): Debian builds for
// baseline x86-64, where the vectoriser has 16-byte registers only. Elsewhere one build.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define SPOOL_VISION_PIXEL_LOOP __attribute__((target_clones("avx2", "default")))
#else
#define SPOOL_VISION_PIXEL_LOOP
#endif
