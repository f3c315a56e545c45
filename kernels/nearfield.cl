/* Explained energy of the near-field search's pair scans (rpm_cl.extract.nearfield).
 *
 * Maths. Candidates m (ni of them) and n (nj) each have an orthonormal basis
 * of two projected atoms, Qm and Qn (N x 2).  With C = Qm^H Qn, the
 * coefficients g = Q^H S of the projected data S (N x G), Pm = g_m g_m^H,
 * Pn = g_n g_n^H and X = g_m g_n^H (all 2 x 2), the energy of S explained
 * jointly by m and n is
 *     |g_m|^2 + tr((I - C^H C)^-1 Y),
 *     Y = Pn - C^H X - X^H C + C^H Pm C
 * (block elimination of the joint Gram matrix [[I, C], [C^H, I]]).  D =
 * I - C^H C is regularised by 1e-12 of its trace; tr(D^-1 Y) =
 * tr(adj(D) Y) / det(D), and 0 where det(D) <= DEGENERATE_DET (a build
 * option, rpm_cl.extract.nearfield.DEGENERATE_DET: a pair whose atoms span fewer
 * than four dimensions, where det and tr are both rounding noise).
 *
 * The host computes the products over the antennas and gates with BLAS:
 * c and x are the (2 ni, 2 nj) complex matrices Fm^H Fn and Gm Gn^H (row
 * 2 i + a, column 2 j + b), pm (ni, 2, 2) and pn (nj, 2, 2) complex, em (ni)
 * = |g_m|^2.  Complex numbers are double2 (re, im), float64 throughout.
 *
 * Work-item mapping: a 2-D range (nj, ni), one work-item per pair (j, i);
 * out (ni, nj) row-major; straight-line code, no loops.
 * NumPy reference: rpm_cl.extract.nearfield_model._pair_algebra.
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable

typedef double2 cplx;

inline cplx cmul(cplx a, cplx b) { return (cplx)(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x); }
/* conj(a) b */
inline cplx cmulc(cplx a, cplx b) { return (cplx)(a.x * b.x + a.y * b.y, a.x * b.y - a.y * b.x); }
inline cplx cscale(double s, cplx a) { return (cplx)(s * a.x, s * a.y); }
inline double cabs2(cplx a) { return a.x * a.x + a.y * a.y; }

__kernel void pair_energy(__global const cplx *c, __global const cplx *x,
                          __global const cplx *pm, __global const cplx *pn,
                          __global const double *em, __global double *out,
                          const int ni, const int nj)
{
    const int j = get_global_id(0);
    const int i = get_global_id(1);
    if (i >= ni || j >= nj) return;
    const long w = 2L * nj;                       /* row length of c and x */
    const long r0 = (2L * i) * w + 2L * j, r1 = r0 + w;
    const cplx c00 = c[r0], c01 = c[r0 + 1], c10 = c[r1], c11 = c[r1 + 1];
    const cplx x00 = x[r0], x01 = x[r0 + 1], x10 = x[r1], x11 = x[r1 + 1];
    const double pm00 = pm[4 * i].x, pm11 = pm[4 * i + 3].x;
    const cplx pm01 = pm[4 * i + 1];
    const double pn00 = pn[4 * j].x, pn11 = pn[4 * j + 3].x;
    const cplx pn01 = pn[4 * j + 1];
    const cplx pm10 = (cplx)(pm01.x, -pm01.y);

    const double a00 = cabs2(c00) + cabs2(c10), a11 = cabs2(c01) + cabs2(c11);
    const cplx d01 = -(cmulc(c00, c01) + cmulc(c10, c11));
    /* Pm C, column by column */
    const cplx e00 = cscale(pm00, c00) + cmul(pm01, c10);
    const cplx e10 = cmul(pm10, c00) + cscale(pm11, c10);
    const cplx e01 = cscale(pm00, c01) + cmul(pm01, c11);
    const cplx e11 = cmul(pm10, c01) + cscale(pm11, c11);
    const double y00 = pn00 - 2.0 * (cmulc(c00, x00) + cmulc(c10, x10)).x
                       + (cmulc(c00, e00) + cmulc(c10, e10)).x;
    const double y11 = pn11 - 2.0 * (cmulc(c01, x01) + cmulc(c11, x11)).x
                       + (cmulc(c01, e01) + cmulc(c11, e11)).x;
    const cplx y01 = pn01 - (cmulc(c00, x01) + cmulc(c10, x11))
                     - (cmulc(x00, c01) + cmulc(x10, c11))
                     + cmulc(c00, e01) + cmulc(c10, e11);
    double d00 = 1.0 - a00, d11 = 1.0 - a11;
    const double eps = 1e-12 * (d00 + d11);
    d00 += eps;
    d11 += eps;
    const double det = d00 * d11 - cabs2(d01);
    const double tr = d11 * y00 + d00 * y11 - 2.0 * cmulc(d01, y01).x;
    out[(long)i * nj + j] = em[i] + (det > DEGENERATE_DET ? tr / det : 0.0);
}

