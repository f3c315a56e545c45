/* Micro-benchmarks of the device's limits, for the roofline columns of
 * `rpm-cl bench` (rpm_cl/cli/limits.py).
 *
 * peak_fma: each work-item runs NACC independent chains of vector
 * multiply-adds a = a * b + c (one contraction per statement, so one FMA
 * instruction per vector where the target has FMA), `iters` times: the
 * arithmetic peak of REALV code as this compiler emits it, 2 * VW * NACC
 * floating-point operations per iteration.  b < 1 and c > 0 keep every
 * chain at a normal, finite value (it tends to c / (1 - b)), so no
 * denormal or overflow slows a lane.
 *
 * stream_read: each work-item sums `per` consecutive vectors of `a`: the
 * read bandwidth of memory, one pass, no reuse.  The sums are written out
 * so that nothing is optimised away.
 *
 * Operators only in the loops (PoCL does not inline built-in calls here,
 * see kernels/simd.h); hsum once at the end.
 */
#include "real.h"
#include "simd.h"

#define NACC 8

__kernel void peak_fma(__global REAL *out, const int iters, const REAL b, const REAL c)
{
    const int g = get_global_id(0);
    const REALV s = (REALV)((REAL)g * (REAL)1e-6);
    REALV a0 = s, a1 = s + (REAL)0.1, a2 = s + (REAL)0.2, a3 = s + (REAL)0.3;
    REALV a4 = s + (REAL)0.4, a5 = s + (REAL)0.5, a6 = s + (REAL)0.6, a7 = s + (REAL)0.7;
    for (int k = 0; k < iters; ++k) {
        a0 = a0 * b + c;
        a1 = a1 * b + c;
        a2 = a2 * b + c;
        a3 = a3 * b + c;
        a4 = a4 * b + c;
        a5 = a5 * b + c;
        a6 = a6 * b + c;
        a7 = a7 * b + c;
    }
    out[g] = hsum(((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7)));
}

__kernel void stream_read(__global const REAL *a, const long per, __global REAL *out)
{
    const int g = get_global_id(0);
    const long v0 = (long)g * per;
    REALV s0 = (REALV)((REAL)0), s1 = s0, s2 = s0, s3 = s0;
    for (long v = 0; v < per; v += 4) {
        s0 += VROW(a, v0 + v);
        s1 += VROW(a, v0 + v + 1);
        s2 += VROW(a, v0 + v + 2);
        s3 += VROW(a, v0 + v + 3);
    }
    out[g] = hsum((s0 + s1) + (s2 + s3));
}
