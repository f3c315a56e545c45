/* Vector helpers that stay inline on PoCL's CPU device.
 *
 * PoCL links its built-in functions into the kernel but does not inline them
 * on this build (its kernel library and the kernel are compiled for
 * different CPU feature sets), so sqrt(float8) becomes a call, and a call in
 * a hot loop spills every vector register.  VSQRT(x) takes the square root
 * of a REALV (float8 or double4, 256 bits) with the AVX instruction where the
 * compiler targets x86 with AVX, and with the portable sqrt elsewhere
 * (GPUs, Oclgrind's SPIR target): the same IEEE-rounded result either way.
 */
#ifndef RPM_SIMD_H
#define RPM_SIMD_H
#include "real.h"

#if defined(__x86_64__) && defined(__AVX__)
typedef float rpm_v8sf __attribute__((vector_size(32)));
typedef double rpm_v4df __attribute__((vector_size(32)));
inline float8 rpm_sqrt_f8(const float8 x)
{
    union { float8 e; rpm_v8sf g; } u;
    u.e = x;
    u.g = __builtin_ia32_sqrtps256(u.g);
    return u.e;
}
#if defined(REAL_IS_DOUBLE)
inline double4 rpm_sqrt_d4(const double4 x)
{
    union { double4 e; rpm_v4df g; } u;
    u.e = x;
    u.g = __builtin_ia32_sqrtpd256(u.g);
    return u.e;
}
#define VSQRT(x) rpm_sqrt_d4(x)
#else
#define VSQRT(x) rpm_sqrt_f8(x)
#endif
#else
#define VSQRT(x) sqrt(x)
#endif

#endif
