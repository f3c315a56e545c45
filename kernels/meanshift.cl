/* Newton / mean-shift steps of 3-D RPM points to a mode of the exhaustive
 * eq. 10 density, and that density at given points.
 *
 * Maths. For main RP i the exhaustive kernel density of a point p (main
 * antenna's frame) is
 *     f(p) = sum_{j<k} g_jk exp(-|p - c_jk|^2 / (2 sigma_r^2))
 * over every valid triplet (i, j, k) of i's cluster, c_jk the intersection
 * (triplet.h, the maths of spheres.cl) and g_jk = w_j + w_k the eq. 11 weight,
 * w = amp exp(-|a|^2 / (2 sigma_D^2)).  Mean shift moves p by
 *     sum g G d / sum g G,   G = exp(-|d|^2 / (2 sigma_r^2)),  d = c - p,
 * which climbs f, but slowly (linearly, the slower the wider the candidates
 * spread against sigma_r); where log f is concave enough at p the step is
 * Newton's on log f instead, from the same pass's second moments
 * (newton_step), which converges quadratically.  At most `iters` steps,
 * fewer when a step is shorter than sqrt(tol2) or no candidate is near.
 * The pass of the last step also gives f at the point it started from
 * (density) and the MS_NEAR_K candidates
 * nearest to that point: no extra pass.  density_spheres then gives f at a
 * few given points (the exhaustive score of candidates, to pick the argmax
 * among those nearest the mode).
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
 * Candidate store (use_store, where the host's chunk fits it): the first
 * pass gathers every sub RP (no pruning) and writes each vector of
 * intersections (x NaN in lanes that are not a valid triplet) to the
 * work-item's run of `store` (3 planes); the later passes
 * and a density_spheres call with `reuse` read them back (with the rows
 * gathered in the scratch, which no later pass overwrites) instead of
 * intersecting again (the intersections and the nearest list take two
 * thirds of a pass on the human body), and the nearest list is made once,
 * after the last step, from the store.  The same pairs in the same order
 * as a sweep whose pruning drops nothing, so the same sums; where pruning
 * would drop sub RPs their masked lanes shift the vectors, a float
 * rounding's difference.
 *
 * Outputs: mode (3, n) (the point after the last step), density (n,) (f at
 * the last point evaluated; 0: no candidate within cut, or iters = 0),
 * nearest (3, MS_NEAR_K, n) (the candidates within cut nearest to that
 * point, nearest first, ties in pair order; the point itself in the slots
 * beyond count), count (n,) (how many slots hold candidates), qcount (2, n)
 * (the rows gathered, -1 where nothing is stored, and the near ones).  The nearest
 * are kept in a sorted private list; a vector of candidates is looked at
 * lane by lane only when one of them beats the list's last entry (rarely,
 * once the list is full).
 * NumPy references: rpm_cl.rpm.reference.meanshift_spheres, density_spheres.
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
typedef union { INTV v; IDX a[VW]; } ilanes_t;

#ifndef MS_NEAR_K
#define MS_NEAR_K 16
#endif
#ifndef MS_NEWTON_PIVOT
#define MS_NEWTON_PIVOT 0.1
#endif
#ifndef MS_DENSITY_T
#define MS_DENSITY_T 4   /* most points per main RP in one density_spheres call */
#endif

/* Nonzero where any lane of the mask m is set (swizzles and |: inline on
 * PoCL, where any() is a call). */
#if VW == 8
#define VANY4(m) ((m).x | (m).y | (m).z | (m).w)
#define VANY(m) VANY4((m).lo | (m).hi)
#else
#define VANY(m) ((m).x | (m).y | (m).z | (m).w)
#endif

/* Candidate (d2; c) into the sorted list of the nearest (*kn entries, at most
 * MS_NEAR_K; kc holds 3 planes of MS_NEAR_K); equal distances keep their order. */
inline void keep_nearest(REAL *kd, REAL *kc, int *kn, const REAL d2, const REAL cx,
                         const REAL cy, const REAL cz)
{
    int q;
    if (*kn < MS_NEAR_K) q = (*kn)++;
    else if (d2 < kd[MS_NEAR_K - 1]) q = MS_NEAR_K - 1;
    else return;
    for (; q > 0 && d2 < kd[q - 1]; --q) {
        kd[q] = kd[q - 1];
        for (int d = 0; d < 3; ++d) kc[d * MS_NEAR_K + q] = kc[d * MS_NEAR_K + q - 1];
    }
    kd[q] = d2;
    kc[q] = cx;
    kc[MS_NEAR_K + q] = cy;
    kc[2 * MS_NEAR_K + q] = cz;
}

/* Sub RPs of main RP i (cluster lo .. hi) whose sphere passes within `cut`
 * of p, near ones first, into the scratch rows (a_x, a_z, b, |a|, w: the
 * per-sub-RP terms of triplet.h and eq. 11, formed once per pass); returns
 * their number and the near count in *mnear. */
inline int gather(__global const REAL *x, __global const REAL *z, __global const REAL *r,
                  __global const REAL *amp, const int lo, const int hi, const int i,
                  const REAL px, const REAL py, const REAL pz, const REAL cut,
                  const REAL far2, const REAL inv2sd2, __global REAL *gx, const long plane,
                  int *mnear, const int prune)
{
    const REAL xi = x[i], zi = z[i], ri = r[i];
    int m = 0;
    for (int pass = 0; pass < 2; ++pass) {
        for (int k = lo; k < hi; ++k) {
            const REAL ax = x[k] - xi, az = z[k] - zi;
            const REAL n2 = ax * ax + az * az;
            if (n2 == (REAL)0 || (n2 <= far2) != (pass == 0)) continue;
            const REAL dx = px - ax, dz = pz - az;
            if (prune && fabs(sqrt(dx * dx + py * py + dz * dz) - r[k]) > cut) continue;
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

/* The pair sweep both passes share: for each gathered near sub RP j and the
 * sub RPs k > j a vector at a time, the intersection c (cx, cy, cz), then
 * d = c - p (dx, dy, dz; 0 in masked lanes, which may hold NaN), d2 = |d|^2,
 * ok (valid and within cut of p) and wg = g G (0 where not ok) are in scope
 * of the statements __VA_ARGS__.  Uses the caller's gx, plane, m, mnear, ri,
 * eps_det, cut2 and l2inv2sr2. */
#define STORE_ROW(p, q) (((__global REALV *)(p))[q])

/* What the sweeps below share for a vector of candidates (cx, cy, cz) with
 * pair weights g_ and lanes ok: d = c - p, 0 in lanes that are not ok or
 * farther than the cutoff (which may hold NaN), d2 = |d|^2, and the kernel
 * term wg = g G. */
#define CANDIDATE_TERMS(px, py, pz)                                                         \
    REALV dx = cx - (px), dy = cy - (py), dz = cz - (pz);                                   \
    const REALV d2 = dx * dx + dy * dy + dz * dz;                                           \
    ok &= d2 <= cut2;                                                                       \
    dx = ok ? dx : zero_;                                                                   \
    dy = ok ? dy : zero_;                                                                   \
    dz = ok ? dz : zero_;                                                                   \
    const REALV wg = ok ? g_ * vexp2_neg(-d2 * l2inv2sr2) : zero_;

#define SWEEP_PAIRS(px, py, pz, STORE, NQP, ...)                                            \
    {                                                                                       \
        __global const REAL *gz_ = gx + plane, *gb_ = gz_ + plane, *gn_ = gb_ + plane;      \
        __global const REAL *gw_ = gn_ + plane;                                             \
        const int nv_ = (m + VW - 1) / VW;                                                  \
        const REALV zero_ = (REALV)((REAL)0);                                               \
        int q_ = 0;                                                                         \
        for (int j = 0; j < mnear; ++j) {                                                   \
            const REALV ajx = (REALV)gx[j], ajz = (REALV)gz_[j], bj = (REALV)gb_[j];        \
            const REALV ej = (REALV)(eps_det * gn_[j]), wj = (REALV)gw_[j];                 \
            for (int c = (j + 1) / VW; c < nv_; ++c) {                                      \
                REALV cx, cy, cz;                                                           \
                const INTV tri_ = triplet_v(ajx, ajz, bj, ej, VROW(gx, c), VROW(gz_, c),    \
                                            VROW(gb_, c), VROW(gn_, c), (REALV)ri, &cx, &cy, \
                                            &cz);                                           \
                INTV ok = tri_ & ((LANES + (IDX)(c * VW)) > (IDX)j);                        \
                const REALV g_ = wj + VROW(gw_, c);                                         \
                if (STORE) {   /* NaN: no valid triplet (d2 <= cut2 then fails) */          \
                    STORE_ROW(STORE, q_) = tri_ ? cx : (REALV)((REAL)NAN);                  \
                    STORE_ROW(STORE + splane, q_) = cy;                                     \
                    STORE_ROW(STORE + 2 * splane, q_) = cz;                                 \
                    ++q_;                                                                   \
                }                                                                           \
                CANDIDATE_TERMS(px, py, pz)                                                 \
                __VA_ARGS__                                                                 \
            }                                                                               \
        }                                                                                   \
        if (STORE) *(NQP) = q_;                                                             \
    }

/* The same sweep over the candidates SWEEP_PAIRS stored at STORE: the
 * same pairs (j, c) of the gathered rows in the same order, so the same
 * sums, with the intersections read back (NaN x: not a valid triplet) and
 * the pair weights and the k > j lanes formed again from the rows. */
#define SWEEP_STORED(px, py, pz, STORE, ...)                                                \
    {                                                                                       \
        __global const REAL *gw_ = gx + 4 * plane;                                          \
        const int nv_ = (m + VW - 1) / VW;                                                  \
        const REALV zero_ = (REALV)((REAL)0);                                               \
        int q_ = 0;                                                                         \
        for (int j = 0; j < mnear; ++j) {                                                   \
            const REALV wj = (REALV)gw_[j];                                                 \
            for (int c = (j + 1) / VW; c < nv_; ++c, ++q_) {                                \
                const REALV cx = STORE_ROW(STORE, q_), cy = STORE_ROW(STORE + splane, q_);  \
                const REALV cz = STORE_ROW(STORE + 2 * splane, q_);                         \
                INTV ok = (LANES + (IDX)(c * VW)) > (IDX)j;                                 \
                const REALV g_ = wj + VROW(gw_, c);                                         \
                CANDIDATE_TERMS(px, py, pz)                                                 \
                __VA_ARGS__                                                                 \
            }                                                                               \
        }                                                                                   \
    }

/* Kernel sums at p over the gathered pairs: s = sum g G, m1 = sum g G d,
 * m2 = sum g G d d^T (xx, yy, zz, xy, xz, yz), d = c - p, and the candidates
 * nearest to p (kd, kc, *kn: see keep_nearest).  With `stored` the pairs
 * are the *nq candidate vectors of `store` (SWEEP_STORED); else they are
 * intersected, and written to `store` when it is not null (their count to
 * *nq). */
#define SHIFT_BODY                                                                          \
        const REALV wx = wg * dx, wy = wg * dy, wz = wg * dz;                               \
        s += wg;                                                                            \
        sx += wx;                                                                           \
        sy += wy;                                                                           \
        sz += wz;                                                                           \
        sxx += wx * dx;                                                                     \
        syy += wy * dy;                                                                     \
        szz += wz * dz;                                                                     \
        sxy += wx * dy;                                                                     \
        sxz += wx * dz;                                                                     \
        syz += wy * dz;                                                                     \
        NEAREST_BODY

/* The nearest-list part of a sweep's body (see keep_nearest). */
#define NEAREST_BODY                                                                        \
        const INTV hit = ok & (d2 < (REALV)last);                                           \
        if (keep && VANY(hit)) {   /* rare once the list is full: lane by lane */           \
            ilanes_t h;                                                                     \
            lanes_t ld, ux, uy, uz;                                                         \
            h.v = hit;                                                                      \
            ld.v = d2;                                                                      \
            ux.v = cx;                                                                      \
            uy.v = cy;                                                                      \
            uz.v = cz;                                                                      \
            for (int q = 0; q < VW; ++q)                                                    \
                if (h.a[q]) keep_nearest(kd, kc, kn, ld.a[q], ux.a[q], uy.a[q], uz.a[q]);   \
            if (*kn == MS_NEAR_K) last = kd[MS_NEAR_K - 1];                                 \
        }

inline REAL shift_sums(__global const REAL *gx, const long plane, const int m,
                       const int mnear, const REAL ri, const REAL px, const REAL py,
                       const REAL pz, const REAL cut2, const REAL l2inv2sr2, const REAL eps_det,
                       REAL *m1, REAL *m2, REAL *kd, REAL *kc, int *kn, __global REAL *store,
                       const long splane, const int stored, int *nq, const int keep)
{
    REALV s = (REALV)((REAL)0), sx = s, sy = s, sz = s, sxx = s, syy = s, szz = s, sxy = s;
    REALV sxz = s, syz = s;
    REAL last = (REAL)2 * cut2;   /* a candidate nearer than this enters the list */
    *kn = 0;
    if (stored)
        SWEEP_STORED(px, py, pz, store, SHIFT_BODY)
    else
        SWEEP_PAIRS(px, py, pz, store, nq, SHIFT_BODY)
    m1[0] = hsum(sx);
    m1[1] = hsum(sy);
    m1[2] = hsum(sz);
    m2[0] = hsum(sxx);
    m2[1] = hsum(syy);
    m2[2] = hsum(szz);
    m2[3] = hsum(sxy);
    m2[4] = hsum(sxz);
    m2[5] = hsum(syz);
    return hsum(s);
}

/* The candidates of the store nearest to p (kd, kc, *kn), alone: the list
 * shift_sums keeps, in the same order and with the same ties. */
inline void nearest_stored(__global const REAL *gx, const long plane, const int m,
                           const int mnear, const REAL px, const REAL py, const REAL pz,
                           const REAL cut2, const REAL l2inv2sr2, REAL *kd, REAL *kc, int *kn,
                           __global REAL *store, const long splane)
{
    const int keep = 1;
    REAL last = (REAL)2 * cut2;
    *kn = 0;
    SWEEP_STORED(px, py, pz, store, NEAREST_BODY)
}

/* The step from p given the sums at p: Newton's on log f,
 *     dp = (I - V / sigma_r^2)^-1 b,   b = m1 / s (the mean-shift step),
 * V = m2 / s - b b^T the kernel-weighted covariance of the candidates (the
 * Hessian of log f is -(I - V / sigma_r^2) / sigma_r^2, its gradient
 * b / sigma_r^2): exact in one step for a single Gaussian, quadratic
 * convergence near a mode.  Taken where every Cholesky pivot of that matrix
 * is at least MS_NEWTON_PIVOT (log f concave enough: the step is then at most
 * 1 / MS_NEWTON_PIVOT times b), else the mean-shift step b. */
inline void newton_step(const REAL s, const REAL *m1, const REAL *m2, const REAL inv_sr2,
                        REAL *dp)
{
    const REAL q = inv_sr2 / s, piv = (REAL)MS_NEWTON_PIVOT;
    const REAL b0 = m1[0] / s, b1 = m1[1] / s, b2 = m1[2] / s;
    dp[0] = b0;
    dp[1] = b1;
    dp[2] = b2;
    const REAL a00 = 1 - q * m2[0] + inv_sr2 * b0 * b0, a11 = 1 - q * m2[1] + inv_sr2 * b1 * b1;
    const REAL a22 = 1 - q * m2[2] + inv_sr2 * b2 * b2, a01 = -q * m2[3] + inv_sr2 * b0 * b1;
    const REAL a02 = -q * m2[4] + inv_sr2 * b0 * b2, a12 = -q * m2[5] + inv_sr2 * b1 * b2;
    if (!(a00 >= piv)) return;
    const REAL l00 = sqrt(a00), l10 = a01 / l00, l20 = a02 / l00;
    const REAL p11 = a11 - l10 * l10;
    if (!(p11 >= piv)) return;
    const REAL l11 = sqrt(p11), l21 = (a12 - l20 * l10) / l11;
    const REAL p22 = a22 - l20 * l20 - l21 * l21;
    if (!(p22 >= piv)) return;
    const REAL l22 = sqrt(p22);
    const REAL y0 = b0 / l00, y1 = (b1 - l10 * y0) / l11, y2 = (b2 - l20 * y0 - l21 * y1) / l22;
    dp[2] = y2 / l22;
    dp[1] = (y1 - l21 * dp[2]) / l11;
    dp[0] = (y0 - l10 * dp[1] - l20 * dp[2]) / l00;
}

__kernel void meanshift_spheres(
    __global const REAL *x, __global const REAL *z, __global const REAL *r,
    __global const REAL *amp, __global const int *cstart, __global const int *ccount,
    const int i0, const int n, const int stride, const REAL inv2sd2, const REAL far2,
    const REAL cut, const REAL l2inv2sr2, const REAL eps_det, const int iters, const REAL tol2,
    __global const REAL *point, __global REAL *mode, __global REAL *density,
    __global REAL *nearest, __global int *count, __global REAL *scratch,
    __global REAL *store, const long sstride, const int use_store, __global int *qcount)
{
    const int il = get_global_id(0);
    if (il >= n) return;
    const int i = i0 + il;
    const int lo = cstart[i], hi = lo + ccount[i];
    const long plane = (long)n * stride;
    __global REAL *gx = scratch + (long)il * stride;  /* 5 planes, see gather */
    /* the candidate store: 4 planes of n runs of sstride (candidates are
     * intersected once, in the first pass, and read in the others) */
    const long splane = (long)n * sstride;
    __global REAL *st = use_store ? store + (long)il * sstride : 0;
    const REAL ri = r[i], cut2 = cut * cut;
    REAL p[3] = {point[il], point[n + il], point[2 * n + il]};
    REAL q0[3] = {p[0], p[1], p[2]};   /* the start of the last step */
    REAL m1[3], m2[6], dp[3], kd[MS_NEAR_K], kc[3 * MS_NEAR_K];
    const REAL inv_sr2 = (REAL)2 * l2inv2sr2 * (REAL)0.69314718055994530942;  /* 1 / sigma_r^2 */
    int kn = 0, nq = 0, m = 0, mnear = 0;
    REAL s = (REAL)0;
    for (int t = 0; t < iters; ++t) {
        /* with the store, every sub RP is gathered once (the pruning below
         * is exact, but relative to the first point) */
        if (!use_store || t == 0)
            m = gather(x, z, r, amp, lo, hi, i, p[0], p[1], p[2], cut, far2, inv2sd2, gx, plane,
                       &mnear, !use_store);
        for (int d = 0; d < 3; ++d) q0[d] = p[d];
        /* with the store, the nearest list is made once, after the last step */
        s = shift_sums(gx, plane, m, mnear, ri, p[0], p[1], p[2], cut2, l2inv2sr2, eps_det, m1,
                       m2, kd, kc, &kn, st, splane, use_store && t > 0, &nq, !use_store);
        if (!(s > (REAL)0)) break;
        newton_step(s, m1, m2, inv_sr2, dp);
        REAL step2 = (REAL)0;
        for (int d = 0; d < 3; ++d) {
            step2 += dp[d] * dp[d];
            p[d] += dp[d];
        }
        if (step2 <= tol2) break;
    }
    if (use_store && iters > 0)
        nearest_stored(gx, plane, m, mnear, q0[0], q0[1], q0[2], cut2, l2inv2sr2, kd, kc, &kn,
                       st, splane);
    density[il] = s;
    count[il] = kn;
    qcount[il] = use_store && iters > 0 ? m : -1;   /* the rows gathered; -1: nothing stored */
    qcount[n + il] = mnear;
    for (int d = 0; d < 3; ++d) {
        mode[(long)d * n + il] = p[d];
        for (int q = 0; q < MS_NEAR_K; ++q)
            nearest[((long)d * MS_NEAR_K + q) * n + il] = q < kn ? kc[d * MS_NEAR_K + q] : q0[d];
    }
}

/* f at nt <= MS_DENSITY_T points t_u per main RP (point (3, nt, n), main
 * antennas' frames; density (nt, n)), for points a few mm apart (the
 * candidates nearest to a mode).  Truncation: the candidates within cut of
 * the first point t_0 count for every point.  One Gaussian per candidate,
 * G_0 = exp(-a |c - t_0|^2) (a = 1 / (2 sigma_r^2)); the others follow as
 *     exp(-a |c - t_u|^2) = G_0 exp(y_u),  y_u = 2a (c - t_0) . e_u - a |e_u|^2,
 * e_u = t_u - t_0, with exp(y) by its Taylor series to degree 6: relative
 * error below |y|^7 / 5040 e^|y|, i.e. below 5e-7 while |e_u| <= sigma_r / 10
 * (|c - t_0| <= cut = 4 sigma_r makes |y| <= 0.4), far below float32
 * rounding for the nearby candidates that carry the sum.  One gather around
 * t_0 (cut: the pruning above is exact). */
inline REALV exp_series6(const REALV y)
{
    REALV e = (REALV)((REAL)(1.0 / 720));
    e = e * y + (REAL)(1.0 / 120);
    e = e * y + (REAL)(1.0 / 24);
    e = e * y + (REAL)(1.0 / 6);
    e = e * y + (REAL)0.5;
    e = e * y + (REAL)1;
    return e * y + (REAL)1;
}

__kernel void density_spheres(
    __global const REAL *x, __global const REAL *z, __global const REAL *r,
    __global const REAL *amp, __global const int *cstart, __global const int *ccount,
    const int i0, const int n, const int stride, const REAL inv2sd2, const REAL far2,
    const REAL cut, const REAL l2inv2sr2, const REAL eps_det, const int nt,
    __global const REAL *point, __global REAL *density, __global REAL *scratch,
    __global REAL *store, const long sstride, const int reuse, __global const int *qcount)
{
    const int il = get_global_id(0);
    if (il >= n) return;
    const int i = i0 + il;
    const int lo = cstart[i], hi = lo + ccount[i];
    const long plane = (long)n * stride;
    __global REAL *gx = scratch + (long)il * stride;
    /* with `reuse`, the rows and candidates meanshift_spheres left for this
     * chunk (qcount: rows gathered, -1 where none are stored, and near rows) */
    const long splane = (long)n * sstride;
    __global REAL *st = store + (long)il * sstride;
    const int mst = reuse ? qcount[il] : -1, mnst = reuse ? qcount[n + il] : 0;
    const REAL ri = r[i], cut2 = cut * cut;
    const REAL a = l2inv2sr2 * (REAL)0.69314718055994530942;   /* 1 / (2 sigma_r^2) */
    const REAL t0x = point[il], t0y = point[(long)nt * n + il], t0z = point[2L * nt * n + il];
    REAL ex[MS_DENSITY_T], ey[MS_DENSITY_T], ez[MS_DENSITY_T], e0[MS_DENSITY_T];
    for (int u = 0; u < nt; ++u) {   /* y_u = (c - t_0) . (2a e_u) - a |e_u|^2 */
        const REAL dx = point[(long)u * n + il] - t0x;
        const REAL dy = point[((long)nt + u) * n + il] - t0y;
        const REAL dz = point[(2L * nt + u) * n + il] - t0z;
        ex[u] = 2 * a * dx;
        ey[u] = 2 * a * dy;
        ez[u] = 2 * a * dz;
        e0[u] = -a * (dx * dx + dy * dy + dz * dz);
    }
    REALV s[MS_DENSITY_T];
    for (int u = 0; u < MS_DENSITY_T; ++u) s[u] = (REALV)((REAL)0);
    /* the select (wg is 0 where not ok) keeps the product and the sum
     * unfused: the rounding of the figures in docs/ */
#define DENSITY_BODY                                                                        \
        s[0] += wg;                                                                         \
        for (int u = 1; u < nt; ++u) {                                                      \
            const REALV e = exp_series6(dx * ex[u] + dy * ey[u] + dz * ez[u] + e0[u]);      \
            s[u] += ok ? wg * e : (REALV)((REAL)0);                                         \
        }
    if (mst >= 0) {   /* the rows and candidates the mean shift left */
        const int m = mst, mnear = mnst;
        SWEEP_STORED(t0x, t0y, t0z, st, DENSITY_BODY)
    } else {
        int mnear;
        const int m = gather(x, z, r, amp, lo, hi, i, t0x, t0y, t0z, cut, far2, inv2sd2, gx,
                             plane, &mnear, 1);
        __global REAL *const no_store = 0;
        int nq;
        SWEEP_PAIRS(t0x, t0y, t0z, no_store, &nq, DENSITY_BODY)
    }
#undef DENSITY_BODY
    for (int u = 0; u < nt; ++u) density[(long)u * n + il] = hsum(s[u]);
}
