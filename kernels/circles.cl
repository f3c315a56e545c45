/* Circle-pair intersections for 2-D RPM (paper eq. 6).
 *
 * Maths. Main RP i = (X_i, R_i) and sub RP j = (X_j, R_j) of the same cluster
 * define circles centred on the antennas (X, 0).  In the main antenna's local
 * frame (origin at (X_i, 0)) with d = X_j - X_i, s = R_i + R_j, e = R_i - R_j:
 *     x = (e*s + d*d) / (2d)
 *     y = sqrt((s - |d|)(s + |d|)) * sqrt((|d| - |e|)(|d| + |e|)) / (2|d|)
 * (the Heron-like product form of R_i^2 - x^2: every factor is a sum or a
 * difference of inputs, so the sign test involves one rounding per factor
 * and there is no catastrophic cancellation; float32 and float64 masks can
 * differ only within that rounding of tangency).  The pair is valid iff d != 0 (not the same antenna),
 * s > |d| and |d| > |e| (two distinct real intersections; tangent or disjoint
 * circles are skipped).  Only the y > 0 root is kept.
 * The pair weight is amp_j * exp(-d^2 / (2 sigma_x^2)).
 * Invalid slots get coordinates 0 and weight 0, so scoring needs no branch.
 *
 * Work-item mapping: one work-item per (main RP i, sub slot js) of a chunk of
 * n main RPs starting at RP i0, flattened as gid = (i - i0)*maxc + js; sub RP
 * j = cstart[i] + js, valid only for js < ccount[i] and j != i.  Indices are
 * 64-bit (n*maxc may exceed 2^31 on large devices).
 *
 * Outputs: cand planes (2, n, maxc) local (x, y); w (n, maxc); valid (n, maxc).
 * NumPy reference: rpm_cl.rpm.reference.intersect_circles.
 */
#include "real.h"

__kernel void intersect_circles(
    __global const REAL *x, __global const REAL *r, __global const REAL *amp,
    __global const int *cstart, __global const int *ccount,
    const int i0, const int n, const int maxc, const REAL inv2sx2,
    __global REAL *cand, __global REAL *w, __global char *valid)
{
    const long gid = get_global_id(0);
    const long plane = (long)n * maxc;
    if (gid >= plane) return;
    const int il = (int)(gid / maxc);
    const int js = (int)(gid - (long)il * maxc);
    const int i = i0 + il;
    const int j = cstart[i] + js;

    REAL cx = (REAL)0, cy = (REAL)0, wt = (REAL)0;
    char ok = 0;
    if (js < ccount[i] && j != i) {
        const REAL ri = r[i], rj = r[j];
        const REAL d = x[j] - x[i];
        const REAL ad = fabs(d);
        const REAL s = ri + rj;
        const REAL e = ri - rj;
        const REAL ae = fabs(e);
        if (d != (REAL)0 && s - ad > (REAL)0 && ad - ae > (REAL)0) {
            cx = (e * s + d * d) / ((REAL)2 * d);
            cy = sqrt((s - ad) * (s + ad)) * sqrt((ad - ae) * (ad + ae)) / ((REAL)2 * ad);
            wt = amp[j] * exp(-d * d * inv2sx2);
            ok = 1;
        }
    }
    cand[gid] = cx;
    cand[plane + gid] = cy;
    w[gid] = wt;
    valid[gid] = ok;
}
