/* Weighted Gaussian kernel-density score of RPM candidates (paper eq. 6, 10).
 *
 * Maths. For main RP i with candidates p_{i,c} (c < maxc) of weight w_{i,c}
 * (0 for invalid slots), the score of candidate l is
 *     score_{i,l} = sum_c w_{i,c} exp(-|p_{i,c} - p_{i,l}|^2 / (2 sigma_r^2))
 * and -1 where candidate l is invalid.  In 2-D, w = amp_j exp(-D^2/2sigma_x^2)
 * (eq. 6); in 3-D, w = g(q_i; q_j, q_k) (eq. 11).  All candidates of one main
 * RP are in the same local frame, so only differences enter.
 *
 * DIM (2 or 3) is set with -DDIM=.  cand holds DIM planes of (n, maxc).
 *
 * Work-item mapping: one work-item per (i, l), gid = i*maxc + l (64-bit); the inner loop
 * over c has the same trip count for every work-item (no branch on validity),
 * which PoCL's CPU device vectorises across work-items.
 * NumPy reference: rpm_cl.rpm.reference.score_candidates.
 *
 * argmax_candidates: one work-item per main RP; first index of the largest
 * score (ties -> lowest index), -1 and score -1 where no candidate is valid;
 * also gathers the chosen candidate's DIM coordinates into point (DIM, n)
 * (0 where none).
 * NumPy reference: rpm_cl.rpm.reference.argmax_candidates.
 */
#include "real.h"
#ifndef DIM
#define DIM 2
#endif

__kernel void score_candidates(
    __global const REAL *cand, __global const REAL *w, __global const char *valid,
    const int n, const int maxc, const REAL inv2sr2, __global REAL *score)
{
    const long gid = get_global_id(0);
    const long plane = (long)n * maxc;
    if (gid >= plane) return;
    const long row = (gid / maxc) * maxc;

    const REAL lx = cand[gid];
    const REAL ly = cand[plane + gid];
#if DIM == 3
    const REAL lz = cand[2 * plane + gid];
#endif
    REAL acc = (REAL)0;
    for (int c = 0; c < maxc; ++c) {
        const long k = row + c;
        const REAL dx = cand[k] - lx;
        const REAL dy = cand[plane + k] - ly;
        REAL d2 = dx * dx + dy * dy;
#if DIM == 3
        const REAL dz = cand[2 * plane + k] - lz;
        d2 += dz * dz;
#endif
        acc += w[k] * exp(-d2 * inv2sr2);
    }
    score[gid] = valid[gid] ? acc : (REAL)(-1);
}

__kernel void argmax_candidates(
    __global const REAL *score, __global const REAL *cand, const int n, const int maxc,
    __global int *best, __global REAL *best_score, __global REAL *point)
{
    const int i = get_global_id(0);
    if (i >= n) return;
    const long row = (long)i * maxc;
    const long plane = (long)n * maxc;
    int b = -1;
    REAL bs = (REAL)(-1);
    for (int c = 0; c < maxc; ++c) {
        const REAL s = score[row + c];
        if (s >= (REAL)0 && (b < 0 || s > bs)) {
            b = c;
            bs = s;
        }
    }
    best[i] = b;
    best_score[i] = bs;
    for (int d = 0; d < DIM; ++d)
        point[(long)d * n + i] = b >= 0 ? cand[d * plane + row + b] : (REAL)0;
}
