/* Delay-and-sum (SAR back-projection) of range-compressed baseband profiles.
 *
 * Maths. Antennas a at (X_a, 0, Z_a) hold s_a(R) on the uniform range axis
 * R_i = r0 + i dr, with the phase exp(-j 2 k_c R_t) at a target of range R_t.
 * The image at voxel p is
 *     I(p) = sum_a s_a(d_a) exp(+j 2 k_c d_a),   d_a = |p - (X_a, 0, Z_a)|
 * with s_a(d) interpolated linearly between the two samples around d (the
 * baseband profiles are smooth: many samples per range resolution), and 0
 * outside the range axis.  2-D images use Z_a = 0 and voxel z = 0.
 *
 * Layout. The image is (rows, nlast) in C order: rows = nx (2-D) or nx*ny
 * (3-D) and the last axis is y (2-D) or z (3-D).  A chunk covers rows
 * row0 .. row0 + nrows - 1.  Row r has fixed coordinates (x, y) in 3-D or x
 * in 2-D; see row_x / row_y below.
 *
 * Work-item mapping: a 2-D range, dim 0 = group of VW consecutive voxels
 * along the last axis, dim 1 = row of the chunk.  The VW voxels are computed
 * as one vector (sqrt, sincos on REALV: SIMD on PoCL's CPU device); the
 * REAL4 rows of the VW lanes are loaded whole and transposed into the four
 * REALV planes with swizzles (unpack/shuffle on a CPU), not lane by lane.
 *
 * Evaluation. With d = R_i + f dr (i the sample below d, 0 <= f < 1), the
 * summand is exactly
 *     (s_a[i] (1 - f) + s_a[i+1] f) exp(j 2 k_c (R_i + dr/2)) exp(j 2 k_c dr (f - 1/2))
 *   = (u'_i + w'_i f) exp(j 2 k_c dr (f - 1/2)),  with
 *     u'_i = s_a[i] exp(j 2 k_c (R_i + dr/2)),
 *     w'_i = (s_a[i+1] - s_a[i]) exp(j 2 k_c (R_i + dr/2)).
 * The host supplies, per antenna, nr + 1 rows: row 0 and row nr are zero and
 * row i + 1 holds (u'_i, w'_i) (float64 phases, then rounded), so the kernel
 * gathers one REAL4 per voxel and antenna, a lane outside the axis reads a
 * zero row (no mask), and only the phasor of x = 2 k_c dr (f - 1/2),
 * |x| <= k_c dr, is left instead of a full-range sincos.  With -DPOLY (host:
 * when k_c dr <= 1.1) that phasor is a Taylor polynomial (|x| <= 1.1:
 * truncation below 1e-7, under float32 rounding), else sincos.
 *
 * Speed on PoCL's CPU device: its built-in functions (sqrt, floor, fmax,
 * select, min) are not inlined into the kernel there, and a call inside the
 * antenna loop spills every vector register; the loop therefore uses only
 * operators, conversions and swizzles, and VSQRT (simd.h), which is the AVX
 * instruction on x86 and sqrt elsewhere.
 *
 * NumPy reference: rpm_cl.baselines.das.das_numpy (float64).
 */
#include "real.h"
#include "simd.h"

/* VW, REALV, INTV, IDX, REAL2/4/8/16: simd.h (IDX long for double: comparisons
 * of double4 give long4 masks) */

/* cos and sin of |x| <= 1.1 (Taylor to x^12 / x^11: remainder < 5e-11) */
inline REALV poly_sincos(const REALV x, REALV *c)
{
    const REALV x2 = x * x;
    *c = (REAL)1 + x2 * ((REAL)(-1.0 / 2) + x2 * ((REAL)(1.0 / 24) + x2 * ((REAL)(-1.0 / 720)
         + x2 * ((REAL)(1.0 / 40320) + x2 * ((REAL)(-1.0 / 3628800) + x2 * (REAL)(1.0 / 479001600))))));
    return x * ((REAL)1 + x2 * ((REAL)(-1.0 / 6) + x2 * ((REAL)(1.0 / 120) + x2 * ((REAL)(-1.0 / 5040)
         + x2 * ((REAL)(1.0 / 362880) + x2 * (REAL)(-1.0 / 39916800))))));
}

/* The VW lanes' terms (u' + w' f) exp(j 2 k_c dr (f - 1/2)) added to the
 * sums: lane l's (u', w') row is row_a[l * stride + iv.sl] (stride 0: every
 * lane on one antenna's rows, das_backproject; stride nr + 1: lane l on
 * antenna a + l, das_points), loaded whole and transposed into the four
 * REALV planes with swizzles (unpack/shuffle on a CPU). */
inline void add_terms(__global const REAL4 *row_a, const long stride, const INTV iv,
                      const REALV fr, const REAL kdr, REALV *acc_re, REALV *acc_im)
{
    REALV ur, ui, vr, vi;
#if VW == 8
    {   /* rows of lanes l and l+4 side by side, then a 4 x 8 transpose */
        const REAL8 a0 = (REAL8)(row_a[iv.s0], row_a[4 * stride + iv.s4]);
        const REAL8 a1 = (REAL8)(row_a[stride + iv.s1], row_a[5 * stride + iv.s5]);
        const REAL8 a2 = (REAL8)(row_a[2 * stride + iv.s2], row_a[6 * stride + iv.s6]);
        const REAL8 a3 = (REAL8)(row_a[3 * stride + iv.s3], row_a[7 * stride + iv.s7]);
        const REAL16 p = (REAL16)(a0, a1), q = (REAL16)(a2, a3);
        const REAL16 xy = (REAL16)(p.s08194C5D, q.s08194C5D);
        const REAL16 zw = (REAL16)(p.s2A3B6E7F, q.s2A3B6E7F);
        ur = xy.s018945CD; ui = xy.s23AB67EF;
        vr = zw.s018945CD; vi = zw.s23AB67EF;
    }
#else
    {   /* 4 x 4 transpose */
        const REAL8 p = (REAL8)(row_a[iv.s0], row_a[stride + iv.s1]);
        const REAL8 q = (REAL8)(row_a[2 * stride + iv.s2], row_a[3 * stride + iv.s3]);
        ur = (REAL4)(p.s04, q.s04); ui = (REAL4)(p.s15, q.s15);
        vr = (REAL4)(p.s26, q.s26); vi = (REAL4)(p.s37, q.s37);
    }
#endif
    /* (u' + w' f) exp(j 2 k_c dr (f - 1/2)): the host's rows hold u', w' */
    const REALV pr = ur + vr * fr;
    const REALV pi = ui + vi * fr;
    const REALV x = kdr * fr - (REAL)0.5 * kdr;
    REALV c;
#ifdef POLY
    const REALV sn = poly_sincos(x, &c);
#else
    const REALV sn = sincos(x, &c);
#endif
    /* one contraction per statement: four FMAs */
    *acc_re += pr * c;
    *acc_re -= pi * sn;
    *acc_im += pr * sn;
    *acc_im += pi * c;
}

__kernel void das_backproject(
    __global const REAL4 *uv, const int n_ant, const int nr,
    __global const REAL *ant_x, __global const REAL *ant_z,
    const REAL r0, const REAL inv_dr, const REAL kdr,
    __global const REAL *gx, __global const REAL *gy, __global const REAL *gz,
    const int ny, const int nlast, const int dim,
    const long row0, const int nrows, __global REAL2 *out)
{
    const int q = get_global_id(0);          /* vector group along the last axis */
    const int rl = get_global_id(1);         /* row within the chunk */
    if (rl >= nrows || q * VW >= nlast) return;
    const long row = row0 + rl;
    REAL px, py;
    REALV pl;                                /* last-axis coordinate per lane */
    REAL lastc[VW];
    for (int l = 0; l < VW; ++l) {
        const int k = min(q * VW + l, nlast - 1);
        lastc[l] = (dim == 3) ? gz[k] : gy[k];
    }
    pl = CAT(vload, VW)(0, lastc);
    if (dim == 3) {
        px = gx[row / ny];
        py = gy[row % ny];
    } else {
        px = gx[row];
        py = (REAL)0;
    }

    REALV acc_re = (REALV)((REAL)0), acc_im = (REALV)((REAL)0);
    for (int a = 0; a < n_ant; ++a) {
        const REAL dx = px - ant_x[a];
        REALV d2;
        if (dim == 3) {
            const REALV dz = pl - ant_z[a];
            d2 = dx * dx + py * py + dz * dz;
        } else {
            d2 = dx * dx + pl * pl;         /* 2-D: the last axis is y */
        }
        const REALV d = VSQRT(d2);
        /* t = fractional row: rows 0 and nr are the zero rows */
        REALV t = (d - r0) * inv_dr + (REAL)1;
        /* clamped to [0, nr] as floats (NaN -> 0), so the conversion never
         * sees a value out of int range (a far voxel, a tiny dr) */
        t = (t > (REAL)0) ? t : (REALV)((REAL)0);
        t = (t < (REAL)nr) ? t : (REALV)((REAL)nr);
        const INTV iv = CAT(CAT(convert_, IDX), VW)(t);    /* t >= 0: truncation is floor */
        const REALV fr = t - CAT(convert_, REALV)(iv);
        add_terms(uv + (long)a * (nr + 1), 0, iv, fr, kdr, &acc_re, &acc_im);
    }
    for (int l = 0; l < VW; ++l) {
        const int k = q * VW + l;
        if (k < nlast)
            out[(long)rl * nlast + k] = (REAL2)(((REAL *)&acc_re)[l], ((REAL *)&acc_im)[l]);
    }
}

/* The delay-and-sum value I(p) at scattered points (the coherence test of
 * rpm_cl.rpm.coherence): one work-item per point, the antennas a_lo[p] ..
 * a_hi[p] - 1 summed VW at a time (one lane per antenna, the lanes added at
 * the end), on das_backproject's rows (uv) and with its maths (the host
 * builds it without POLY: in float64 the polynomial's truncation would
 * show).  Antennas at
 * (ant_x, 0, ant_z), points (px, py, pz), both less the same origin.  The
 * host pads uv with VW antennas of zero rows and ant_x, ant_z with VW
 * copies of the last antenna, so that the lanes past a_hi[p] read inside
 * them, and it sets a_lo and a_hi so that the antennas outside them add
 * nothing (on a line, those farther in x than the range axis reaches): the
 * lanes outside read a padding antenna's zero rows or a row beyond the
 * axis, also zero, so they need no mask.
 *
 * NumPy reference: rpm_cl.extract.backprojection.at_points (float64). */
__kernel void das_points(
    __global const REAL4 *uv, const int nr,
    __global const REAL *ant_x, __global const REAL *ant_z,
    const REAL r0, const REAL inv_dr, const REAL kdr,
    __global const REAL *px, __global const REAL *py, __global const REAL *pz,
    __global const int *a_lo, __global const int *a_hi,
    const int n_points, __global REAL2 *out)
{
    const int p = get_global_id(0);
    if (p >= n_points) return;
    const REAL x = px[p], y2 = py[p] * py[p], z = pz[p];
    const int hi = a_hi[p];
    const long st = nr + 1;                   /* rows per antenna */
    REALV acc_re = (REALV)((REAL)0), acc_im = (REALV)((REAL)0);
    /* from a whole vector's start: the lanes before a_lo[p] add nothing
     * either, and the antennas load as plain aligned vectors (VROW) */
    for (int a = (a_lo[p] / VW) * VW; a < hi; a += VW) {
        const REALV dx = (REALV)x - VROW(ant_x, a / VW);
        const REALV dz = (REALV)z - VROW(ant_z, a / VW);
        const REALV d = VSQRT(dx * dx + (REALV)y2 + dz * dz);
        /* rows 0 and nr are the zero rows (das_backproject) */
        REALV t = (d - r0) * inv_dr + (REAL)1;
        t = (t > (REAL)0) ? t : (REALV)((REAL)0);     /* NaN -> 0 */
        t = (t < (REAL)nr) ? t : (REALV)((REAL)nr);
        const INTV iv = CAT(CAT(convert_, IDX), VW)(t);
        const REALV fr = t - CAT(convert_, REALV)(iv);
        add_terms(uv + (long)a * st, st, iv, fr, kdr, &acc_re, &acc_im);
    }
    out[p] = (REAL2)(hsum(acc_re), hsum(acc_im));
}
