/* 256-bit vector types and helpers that stay inline on PoCL's CPU device.
 *
 * REALV is float8 (REAL float) or double4 (REAL_IS_DOUBLE): 256 bits, which
 * PoCL's CPU target turns into AVX instructions.  INTV is the matching
 * integer vector (int8 / long4: comparisons of REALV give INTV masks).
 *
 * Why the helpers: PoCL links its built-in functions into the kernel but
 * does not inline them on this build (its kernel library and the kernel are
 * compiled for different CPU feature sets), so sqrt(float8), exp2(float8),
 * vload8, fmax, min and select each become a call, and a call in a hot loop
 * spills every vector register.  Hot loops use operators, conversions,
 * swizzles, as_type and these helpers instead:
 *   VSQRT(x)     square root: the AVX instruction where the compiler targets
 *                x86 with AVX, the portable sqrt elsewhere (GPUs, Oclgrind's
 *                SPIR target); IEEE-rounded either way.
 *   vexp2_neg(x) 2^x for x <= 0 (0 below the smallest normal exponent),
 *                round-to-nearest split and a Taylor polynomial of e^y,
 *                |y| = |f ln 2| <= 0.347 (remainder < 6e-9 at degree 7,
 *                < 3e-16 at degree 12); relative error below 2e-7 (float) / 1e-14
 *                (double).
 *   VABS(x)      |x| of a REALV by clearing the sign bits.
 *   VROW(p, c)   the c-th REALV of a row of REAL at p (32-byte aligned: the
 *                host pads rows to whole vectors), a plain load, not vload.
 *   hsum(x)      the sum of a REALV's lanes (two dot products; a call on
 *                PoCL, so for the end of a loop, not its body).
 */
#ifndef RPM_SIMD_H
#define RPM_SIMD_H
#include "real.h"

#define CAT(a, b) CAT_(a, b)
#define CAT_(a, b) a##b
#if defined(REAL_IS_DOUBLE)
#define VW 4
#define IDX long
#else
#define VW 8
#define IDX int
#endif
#define REALV CAT(REAL, VW)
#define INTV CAT(IDX, VW)
#define REAL2 CAT(REAL, 2)
#define REAL4 CAT(REAL, 4)
#define REAL8 CAT(REAL, 8)
#define REAL16 CAT(REAL, 16)

#if defined(__x86_64__) && defined(__AVX__)
#if defined(REAL_IS_DOUBLE)
typedef double rpm_v256 __attribute__((vector_size(32)));
#define RPM_SQRT256 __builtin_ia32_sqrtpd256
#else
typedef float rpm_v256 __attribute__((vector_size(32)));
#define RPM_SQRT256 __builtin_ia32_sqrtps256
#endif
inline REALV rpm_sqrt_v(const REALV x)
{
    union { REALV e; rpm_v256 g; } u;   /* same 256 bits, the builtin's vector type */
    u.e = x;
    u.g = RPM_SQRT256(u.g);
    return u.e;
}
#define VSQRT(x) rpm_sqrt_v(x)
#else
#define VSQRT(x) sqrt(x)
#endif

#if defined(REAL_IS_DOUBLE)
#define VABS(v) as_double4(as_long4(v) & (long4)(0x7fffffffffffffffL))
#else
#define VABS(v) as_float8(as_int8(v) & (int8)(0x7fffffff))
#endif
#define VROW(p, c) (((__global const REALV *)(p))[c])

inline REAL hsum(const REALV a)
{
#if VW == 8
    return dot(a.lo, (CAT(REAL, 4))((REAL)1)) + dot(a.hi, (CAT(REAL, 4))((REAL)1));
#else
    return dot(a, (REALV)((REAL)1));
#endif
}

inline REALV vexp2_neg(REALV x)
{
#if defined(REAL_IS_DOUBLE)
    const REAL shifter = 6755399441055744.0;   /* 1.5 * 2^52: adding it rounds to an integer */
    const REAL lowest = -1022.0;
    const int bias = 1023, mant = 52;
#else
    const REAL shifter = 12582912.0f;          /* 1.5 * 2^23 */
    const REAL lowest = -126.0f;
    const int bias = 127, mant = 23;
#endif
    const INTV ok = x >= lowest;
    x = ok ? x : (REALV)lowest;
    const REALV t = x + shifter;
    const REALV f = x - (t - shifter);         /* x - round(x), |f| <= 1/2 */
    const INTV k = CAT(as_, INTV)(t) - CAT(as_, INTV)((REALV)shifter);   /* round(x) */
    const REALV y = f * (REAL)0.69314718055994530942;                    /* f ln 2 */
    /* e^y = sum y^j / j! by Horner, degree 12 (double) or 7 (float) */
#if defined(REAL_IS_DOUBLE)
    REALV p = (REAL)(1.0 / 479001600);
    p = p * y + (REAL)(1.0 / 39916800);
    p = p * y + (REAL)(1.0 / 3628800);
    p = p * y + (REAL)(1.0 / 362880);
    p = p * y + (REAL)(1.0 / 40320);
    p = p * y + (REAL)(1.0 / 5040);
#else
    REALV p = (REAL)(1.0 / 5040);
#endif
    p = p * y + (REAL)(1.0 / 720);
    p = p * y + (REAL)(1.0 / 120);
    p = p * y + (REAL)(1.0 / 24);
    p = p * y + (REAL)(1.0 / 6);
    p = p * y + (REAL)0.5;
    p = p * y + (REAL)1;
    p = p * y + (REAL)1;
    const REALV scale = CAT(as_, REALV)((k + bias) << mant);                /* 2^round(x) */
    return ok ? p * scale : (REALV)((REAL)0);
}

#endif
