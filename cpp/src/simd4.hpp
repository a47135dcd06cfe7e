#pragma once
// Internal to the one-class SVM: 4-lane double vectors (GCC vector extensions, lowered to each
// CPU clone's ISA) and the per-CPU compilation of the hot loops.
#include <cstring>

// The dot products and exponentials behind every kernel value (dot_tile, gaussian_column,
// gaussian_sum) are compiled for three x86-64 levels (AVX-512, AVX2+FMA, baseline SSE2) and
// picked at load time by the CPU (GCC function multi-versioning), since the package is built
// without -march=native. -DMPMPP_NO_CPU_CLONES builds the baseline only.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(MPMPP_NO_CPU_CLONES)
#define MPMPP_CPU_CLONES \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define MPMPP_CPU_CLONES
#endif

namespace mpmpp::detail {

typedef double Vec4 __attribute__((vector_size(32)));
typedef long long Vec4i __attribute__((vector_size(32)));
typedef float Vec4f __attribute__((vector_size(16)));
#define MPMPP_LOAD4(v, ptr) __builtin_memcpy(&(v), (ptr), sizeof(Vec4))
#define MPMPP_STORE4(ptr, v) __builtin_memcpy((ptr), &(v), sizeof(Vec4))

// exp(x) on 4 lanes, within 1 ulp of the correctly rounded value for x in [-708, 709] (inputs
// are clamped to that range; below it the result is 3e-308 instead of a denormal or 0, which
// rounds to the same single-precision 0 and is negligible in a decision sum). Cody-Waite
// reduction x = n ln2 + r, |r| <= ln2 / 2, and the degree-11 Taylor polynomial of e^r (truncation
// error below 1e-21). Inlined into each CPU clone.
__attribute__((always_inline)) inline void vexp(Vec4& x) {
  const Vec4 lo = {-708.0, -708.0, -708.0, -708.0}, hi = {709.0, 709.0, 709.0, 709.0};
  x = x < lo ? lo : x;
  x = x > hi ? hi : x;
  const double shifter = 0x1.8p52;  // adding it rounds to an integer held in the low bits
  const Vec4 t = x * 1.4426950408889634 + shifter;
  const Vec4 n = t - shifter;
  const Vec4 r = (x - n * 6.93147180369123816490e-01) - n * 1.90821492927058770002e-10;
  Vec4 p = r * (1.0 / 39916800) + 1.0 / 3628800;
  p = p * r + 1.0 / 362880;
  p = p * r + 1.0 / 40320;
  p = p * r + 1.0 / 5040;
  p = p * r + 1.0 / 720;
  p = p * r + 1.0 / 120;
  p = p * r + 1.0 / 24;
  p = p * r + 1.0 / 6;
  p = p * r + 0.5;
  p = p * r + 1.0;
  p = p * r + 1.0;
  Vec4i bits;
  __builtin_memcpy(&bits, &t, sizeof bits);
  long long shifter_bits;
  __builtin_memcpy(&shifter_bits, &shifter, sizeof shifter_bits);
  bits = (bits - shifter_bits + 1023) << 52;  // 2^n
  Vec4 scale;
  __builtin_memcpy(&scale, &bits, sizeof scale);
  x = p * scale;
}

}  // namespace mpmpp::detail
