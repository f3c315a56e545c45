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
 * The host passes l2inv2sr2 = log2(e) / (2 sigma_r^2) and the kernel evaluates
 * 2^(-d^2 l2inv2sr2) = exp(-d^2 / (2 sigma_r^2)) with simd.h's inline
 * vexp2_neg (relative error < 2e-7 in float32).
 *
 * Work-item mapping: a 2-D range, one work-item per (l, i); flat index
 * i*maxc + l (64-bit).  maxc must be a multiple of 8 (the host pads rows with
 * invalid, zero-weight slots); the inner loop over c runs 8 candidates at a
 * time with the same trip count for every work-item.
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

/* Vectors over the candidates c (float8 / double4, simd.h): PoCL turns them
 * into SIMD instructions, which its implicit work-item vectoriser does not do
 * for a scalar loop.  The host pads every row to a multiple of 8 slots
 * (padding slots have weight 0), so rows start 32-byte aligned and are read
 * as whole vectors (vload8 and exp2 are calls on PoCL's CPU device, see
 * simd.h; vexp2_neg is inline). */
#include "simd.h"

__kernel void score_candidates(
    __global const REAL *cand, __global const REAL *w, __global const char *valid,
    const int n, const int maxc, const REAL l2inv2sr2, __global REAL *score)
{
    /* 2-D range: dim 0 = candidate l (maxc, a multiple of 8), dim 1 = main RP i */
    const int l = get_global_id(0);
    const int i = get_global_id(1);
    if (l >= maxc || i >= n) return;
    const long plane = (long)n * maxc;
    const long row = (long)i * maxc;
    const long gid = row + l;
    if (!valid[gid]) {
        score[gid] = (REAL)(-1);
        return;
    }
    const REAL lx = cand[gid];
    const REAL ly = cand[plane + gid];
#if DIM == 3
    const REAL lz = cand[2 * plane + gid];
#endif
    const int nv = maxc / VW;
    REALV acc = (REALV)((REAL)0);
    for (int c = 0; c < nv; ++c) {
        const REALV dx = VROW(cand + row, c) - lx;
        const REALV dy = VROW(cand + plane + row, c) - ly;
        REALV d2 = dx * dx + dy * dy;
#if DIM == 3
        const REALV dz = VROW(cand + 2 * plane + row, c) - lz;
        d2 += dz * dz;
#endif
        acc += VROW(w + row, c) * vexp2_neg(-d2 * l2inv2sr2);
    }
    score[gid] = hsum(acc);
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
    /* index clamped: the compiler may load both arms of the select */
    const long bk = row + (b >= 0 ? b : 0);
    for (int d = 0; d < DIM; ++d)
        point[(long)d * n + i] = b >= 0 ? cand[d * plane + bk] : (REAL)0;
}
