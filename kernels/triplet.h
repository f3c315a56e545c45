/* Sphere-triplet intersection (paper eq. 10), shared by spheres.cl and
 * meanshift.cl so that the maths exists once.
 *
 * In the main antenna's frame (origin at the main antenna), sub antennas at
 * a_j = (ajx, ajz) and a_k = (akx, akz) in the array plane, ranges ri, rj, rk:
 *     b_j = ((ri - rj)(ri + rj) + |a_j|^2) / 2   (range difference first: no
 *                                                R^2 - R^2 cancellation)
 *     det = ajx akz - ajz akx,  (px, pz) by Cramer's rule from a . p = b,
 *     rho = |(px, pz)|,  py = sqrt((ri - rho)(ri + rho))   (the y > 0 root)
 * valid iff |det| > eps_det |a_j| |a_k| (not collinear or coincident antennas)
 * and ri - rho > 0 (a real, non-tangent intersection).  Where invalid the
 * outputs may be Inf or NaN: callers select on the mask before using them.
 *
 * The per-sub-RP terms are separate so that a caller pairing one sub RP with
 * many can form them once: TRIPLET_B(ri, rj, nj2) gives b_j, and the
 * threshold enters as ej = eps_det |a_j| and nk = |a_k| (the product
 * eps_det |a_j| |a_k| is rounded in that order either way).
 *
 * RPM_DEFINE_TRIPLET(NAME, T, M, SQRT, ABS) defines
 *     M NAME(ajx, ajz, bj, ej, akx, akz, bk, nk, ri, *px, *py, *pz)
 * for a scalar (T = REAL, M = int, 1 = valid) or a vector type (T = REALV,
 * M = INTV, -1 = valid lane); SQRT and ABS are the square root and absolute
 * value to use (VSQRT and a bit mask for vectors: no calls in hot loops).
 */
#ifndef RPM_TRIPLET_H
#define RPM_TRIPLET_H
#include "real.h"

#define TRIPLET_B(ri, rj, nj2) ((REAL)0.5 * (((ri) - (rj)) * ((ri) + (rj)) + (nj2)))

#define RPM_DEFINE_TRIPLET(NAME, T, M, SQRT, ABS)                                    \
    inline M NAME(const T ajx, const T ajz, const T bj, const T ej, const T akx,     \
                  const T akz, const T bk, const T nk, const T ri, T *px, T *py,     \
                  T *pz)                                                             \
    {                                                                                \
        const T det = ajx * akz - ajz * akx;                                         \
        const M sound = ABS(det) > ej * nk;                                          \
        *px = (bj * akz - bk * ajz) / det;                                           \
        *pz = (ajx * bk - akx * bj) / det;                                           \
        const T rho = SQRT(*px * *px + *pz * *pz);                                   \
        const M real = ri - rho > (T)(0);                                            \
        *py = SQRT((ri - rho) * (ri + rho));                                         \
        return sound & real;                                                         \
    }

#endif
