/* Sphere-triplet intersections for 3-D RPM (paper eq. 10-11).
 *
 * Maths (the intersection itself: triplet.h). RPs q = (X, Z, R) are spheres of radius R centred on antennas
 * (X, 0, Z).  For a main RP i and two sub RPs j, k of its cluster, work in the
 * main antenna's frame (origin at (X_i, 0, Z_i)) with a_j = (X_j - X_i, Z_j - Z_i).
 * Subtracting the sphere equations |p|^2 = R_i^2 and |p - a_j|^2 = R_j^2 gives
 * two linear equations for the in-plane coordinates (p_x, p_z):
 *     a_j . (p_x, p_z) = b_j,   b_j = ((R_i - R_j)(R_i + R_j) + |a_j|^2) / 2
 * (the range difference is formed first, so no R^2 - R^2 cancellation), solved
 * by Cramer's rule with det = a_jx a_kz - a_jz a_kx; then
 *     p_y = sqrt((R_i - rho)(R_i + rho)),  rho = |(p_x, p_z)|
 * (the y > 0 root; the product form keeps its relative accuracy near rho ~ 0).
 * The triplet is valid iff
 *     |det| > EPS_DET * |a_j| |a_k|   (antennas not collinear or coincident;
 *                                      below this the solution is rounding noise)
 *     R_i - rho > 0                   (a real intersection, not tangent)
 * The candidate weight is g of eq. 11:
 *     g = amp_j exp(-|a_j|^2 / (2 sigma_D^2)) + amp_k exp(-|a_k|^2 / (2 sigma_D^2)).
 * Invalid slots get coordinates 0 and weight 0, so scoring needs no branch.
 *
 * Candidate slots. Each main RP i has a list of nnbr[i] <= kmax sub RPs,
 * nbr[i*kmax + 0 .. nnbr[i]-1] (chosen on the host: same cluster, another
 * antenna, within the pairing radius).  Slot s < maxc = kmax(kmax-1)/2 is the
 * pair (pa[s], pb[s]) of list positions, pa < pb, in colex order, so the first
 * nnbr(nnbr-1)/2 slots are exactly the pairs of a list of length nnbr.
 *
 * Work-item mapping: one per (main RP il of the chunk, slot s), gid =
 * il*maxc + s (64-bit), main RP i = i0 + il.
 *
 * Outputs: cand planes (3, n, maxc) local (x, y, z); w (n, maxc); valid (n, maxc).
 * NumPy reference: rpm_cl.rpm.reference.intersect_spheres.
 */
#include "real.h"
#include "triplet.h"   /* the intersection maths, shared with meanshift.cl */

RPM_DEFINE_TRIPLET(triplet_s, REAL, int, sqrt, fabs)

__kernel void intersect_spheres(
    __global const REAL *x, __global const REAL *z, __global const REAL *r,
    __global const REAL *amp, __global const int *nbr, __global const int *nnbr,
    __global const int *pa, __global const int *pb,
    const int i0, const int n, const int kmax, const int maxc,
    const REAL inv2sd2, const REAL eps_det,
    __global REAL *cand, __global REAL *w, __global char *valid)
{
    const long gid = get_global_id(0);
    const long plane = (long)n * maxc;
    if (gid >= plane) return;
    const int il = (int)(gid / maxc);
    const int s = (int)(gid - (long)il * maxc);
    const int i = i0 + il;
    const int la = pa[s], lb = pb[s];

    REAL cx = (REAL)0, cy = (REAL)0, cz = (REAL)0, wt = (REAL)0;
    char ok = 0;
    if (lb < nnbr[i]) {
        const int j = nbr[(long)i * kmax + la];
        const int k = nbr[(long)i * kmax + lb];
        const REAL ajx = x[j] - x[i], ajz = z[j] - z[i];
        const REAL akx = x[k] - x[i], akz = z[k] - z[i];
        const REAL nj2 = ajx * ajx + ajz * ajz, nk2 = akx * akx + akz * akz;
        const REAL ri = r[i];
        REAL px, py, pz;
        if (triplet_s(ajx, ajz, TRIPLET_B(ri, r[j], nj2), eps_det * sqrt(nj2), akx, akz,
                      TRIPLET_B(ri, r[k], nk2), sqrt(nk2), ri, &px, &py, &pz)) {
            cx = px;
            cy = py;
            cz = pz;
            wt = amp[j] * exp(-nj2 * inv2sd2) + amp[k] * exp(-nk2 * inv2sd2);
            ok = 1;
        }
    }
    cand[gid] = cx;
    cand[plane + gid] = cy;
    cand[2 * plane + gid] = cz;
    w[gid] = wt;
    valid[gid] = ok;
}
