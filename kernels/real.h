/* Shared scalar type for rpm-cl kernels.
 * REAL is chosen by the host with -DREAL=float or -DREAL=double (double only
 * where the device's double_fp_config allows it). */
#ifndef RPM_REAL_H
#define RPM_REAL_H
#ifndef REAL
#define REAL float
#endif
#if defined(REAL_IS_DOUBLE)
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif
#endif
