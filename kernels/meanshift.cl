/* Mean shift of 3-D RPM points to a mode of the exhaustive eq. 10 density.
 *
 * Maths. For main RP i the exhaustive kernel density of a point p (main
 * antenna's frame) is
 *     f(p) = sum_{j<k} g_jk exp(-|p - c_jk|^2 / (2 sigma_r^2))
 * over every valid triplet (i, j, k) of i's cluster, c_jk the intersection
 * (triplet.h, the maths of spheres.cl) and g_jk = w_j + w_k the eq. 11 weight,
 * w = amp exp(-|a|^2 / (2 sigma_D^2)).  Mean shift moves p to
 *     sum g G c / sum g G,   G = exp(-|p - c|^2 / (2 sigma_r^2)),
 * which climbs f; at most `iters` steps, fewer when a step is shorter than
 * sqrt(tol2) or no candidate is near.  The pass of the last step also gives
 * f at the point it started from (density) and the candidate nearest to
 * that point: no extra pass.
 * Truncations (stated, and the same in the NumPy reference):
 *   - candidates with |c - p| > cut (MS_CUTOFF sigma_r) are left out;
 *   - pairs whose two sub RPs both lie farther than sqrt(far2) (MS_PAIR_CUTOFF
 *     sigma_D) from the main antenna are left out (g below 2 exp(-8)).
 * Pruning (exact, no further truncation): c_jk lies on sphere k, so
 * |c - p| >= | |p - a_k| - R_k |; a sub RP whose sphere passes farther than
 * `cut` from p cannot give a candidate within the cutoff and is not paired.
 *
 * Work-item mapping: one work-item per main RP il of the chunk (i = i0 + il).
 * Each pass first gathers the sub RPs that survive the pruning (not at the
 * main antenna, sphere within `cut` of p), near ones (|a| <= sqrt(far2))
 * first, into the work-item's own scratch rows (5 planes of (n, stride):
 * a_x, a_z, b, |a|, w; stride >= the cluster size, a multiple of 8, so memory is
 * bounded by the chunk, whatever the cluster), zero-padded to a whole vector
 * (a = 0 makes det = 0: invalid).  Then for each near j it sweeps k > j a
 * vector (float8 / double4, simd.h) at a time: straight-line code, masks
 * instead of branches, no NaN or Inf leaves a masked lane.
 *
 * Outputs: mode (3, n) (the point after the last step), density (n,) (f at
 * the last point evaluated; 0: no candidate within cut, or iters = 0),
 * nearest (3, n) (the candidate nearest to that point; the point itself
 * where there is none).
 * NumPy reference: rpm_cl.rpm.reference.meanshift_spheres.
 */
#include "real.h"
#include "simd.h"
#include "triplet.h"

#if defined(REAL_IS_DOUBLE)
#define LANES ((INTV)(0, 1, 2, 3))
#else
#define LANES ((INTV)(0, 1, 2, 3, 4, 5, 6, 7))
#endif

RPM_DEFINE_TRIPLET(triplet_v, REALV, INTV, VSQRT, VABS)

typedef union { REALV v; REAL a[VW]; } lanes_t;

/* Sub RPs of main RP i (cluster lo .. hi) whose sphere passes within `cut`
 * of p, near ones first, into the scratch rows (a_x, a_z, b, |a|, w: the
 * per-sub-RP terms of triplet.h and eq. 11, formed once per pass); returns
 * their number and the near count in *mnear. */
inline int gather(__global const REAL *x, __global const REAL *z, __global const REAL *r,
                  __global const REAL *amp, const int lo, const int hi, const int i,
                  const REAL px, const REAL py, const REAL pz, const REAL cut,
                  const REAL far2, const REAL inv2sd2, __global REAL *gx, const long plane,
                  int *mnear)
{
    const REAL xi = x[i], zi = z[i], ri = r[i];
    int m = 0;
    for (int pass = 0; pass < 2; ++pass) {
        for (int k = lo; k < hi; ++k) {
            const REAL ax = x[k] - xi, az = z[k] - zi;
            const REAL n2 = ax * ax + az * az;
            if (n2 == (REAL)0 || (n2 <= far2) != (pass == 0)) continue;
            const REAL dx = px - ax, dz = pz - az;
            if (fabs(sqrt(dx * dx + py * py + dz * dz) - r[k]) > cut) continue;
            gx[m] = ax;
            gx[plane + m] = az;
            gx[2 * plane + m] = TRIPLET_B(ri, r[k], n2);
            gx[3 * plane + m] = sqrt(n2);
            gx[4 * plane + m] = amp[k] * exp(-n2 * inv2sd2);
            ++m;
        }
        if (pass == 0) *mnear = m;
    }
    for (int q = m; q % VW; ++q)  /* a = 0: det = 0, invalid */
        for (int d = 0; d < 5; ++d) gx[d * plane + q] = (REAL)0;
    return m;
}

/* Kernel sums at p over the gathered pairs: s = sum g G, sc = sum g G c, and
 * the candidate nearest to p (*near, unchanged where there is none). */
inline REAL shift_sums(__global const REAL *gx, const long plane, const int m,
                       const int mnear, const REAL ri, const REAL px, const REAL py,
                       const REAL pz, const REAL cut2, const REAL l2inv2sr2, const REAL eps_det,
                       REAL *sc, REAL *near)
{
    __global const REAL *gz = gx + plane, *gb = gz + plane, *gn = gb + plane, *gw = gn + plane;
    const int nv = (m + VW - 1) / VW;
    REALV s = (REALV)((REAL)0), sx = s, sy = s, sz = s, bx = s, by = s, bz = s;
    REALV bd = (REALV)((REAL)2 * cut2);
    for (int j = 0; j < mnear; ++j) {
        const REALV ajx = (REALV)gx[j], ajz = (REALV)gz[j], bj = (REALV)gb[j];
        const REALV ej = (REALV)(eps_det * gn[j]), wj = (REALV)gw[j];
        for (int c = (j + 1) / VW; c < nv; ++c) {
            REALV cx, cy, cz;
            INTV ok = triplet_v(ajx, ajz, bj, ej, VROW(gx, c), VROW(gz, c), VROW(gb, c),
                                VROW(gn, c), (REALV)ri, &cx, &cy, &cz);
            ok &= (LANES + (IDX)(c * VW)) > (IDX)j;
            const REALV dx = cx - px, dy = cy - py, dz = cz - pz;
            const REALV d2 = dx * dx + dy * dy + dz * dz;
            ok &= d2 <= cut2;
            const REALV wg = ok ? (wj + VROW(gw, c)) * vexp2_neg(-d2 * l2inv2sr2)
                                : (REALV)((REAL)0);
            s += wg;
            sx += wg * (ok ? cx : (REALV)((REAL)0));
            sy += wg * (ok ? cy : (REALV)((REAL)0));
            sz += wg * (ok ? cz : (REALV)((REAL)0));
            const INTV better = ok & (d2 < bd);
            bd = better ? d2 : bd;
            bx = better ? cx : bx;
            by = better ? cy : by;
            bz = better ? cz : bz;
        }
    }
    sc[0] = hsum(sx);
    sc[1] = hsum(sy);
    sc[2] = hsum(sz);
    lanes_t d, ux, uy, uz;
    d.v = bd;
    ux.v = bx;
    uy.v = by;
    uz.v = bz;
    REAL best = (REAL)2 * cut2;
    for (int q = 0; q < VW; ++q) {
        if (d.a[q] < best) {
            best = d.a[q];
            near[0] = ux.a[q];
            near[1] = uy.a[q];
            near[2] = uz.a[q];
        }
    }
    return hsum(s);
}

__kernel void meanshift_spheres(
    __global const REAL *x, __global const REAL *z, __global const REAL *r,
    __global const REAL *amp, __global const int *cstart, __global const int *ccount,
    const int i0, const int n, const int stride, const REAL inv2sd2, const REAL far2,
    const REAL cut, const REAL l2inv2sr2, const REAL eps_det, const int iters, const REAL tol2,
    __global const REAL *point, __global REAL *mode, __global REAL *density,
    __global REAL *nearest, __global REAL *scratch)
{
    const int il = get_global_id(0);
    if (il >= n) return;
    const int i = i0 + il;
    const int lo = cstart[i], hi = lo + ccount[i];
    const long plane = (long)n * stride;
    __global REAL *gx = scratch + (long)il * stride;  /* 5 planes, see gather */
    const REAL ri = r[i], cut2 = cut * cut;
    REAL p[3] = {point[il], point[n + il], point[2 * n + il]};
    REAL sc[3], near[3] = {p[0], p[1], p[2]};
    REAL s = (REAL)0;
    for (int t = 0; t < iters; ++t) {
        int mnear;
        const int m = gather(x, z, r, amp, lo, hi, i, p[0], p[1], p[2], cut, far2, inv2sd2,
                             gx, plane, &mnear);
        near[0] = p[0];
        near[1] = p[1];
        near[2] = p[2];
        s = shift_sums(gx, plane, m, mnear, ri, p[0], p[1], p[2], cut2, l2inv2sr2, eps_det, sc,
                       near);
        if (!(s > (REAL)0)) break;
        REAL step2 = (REAL)0;
        for (int d = 0; d < 3; ++d) {
            const REAL q = sc[d] / s;
            step2 += (q - p[d]) * (q - p[d]);
            p[d] = q;
        }
        if (step2 <= tol2) break;
    }
    density[il] = s;
    for (int d = 0; d < 3; ++d) {
        mode[(long)d * n + il] = p[d];
        nearest[(long)d * n + il] = near[d];
    }
}
