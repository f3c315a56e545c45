"""One BLAS thread for the host's many small matrix products.

The decomposition's DFT matrices (:mod:`rpm_cl.extract.kspace`) and the near-field
search (:mod:`rpm_cl.extract.nearfield`) multiply thousands of small matrices
(tens of rows).  OpenBLAS's threads cost more than they save there, and
after each call they keep spinning for a while, taking the cores from the
OpenCL kernels that run next.  Measured on the 2-core reference machine:
the paper's sparse case 0.20 s with OpenBLAS's default threads against
0.11 s with one; the human body's RPM stage 100 ms against 76 ms right
after a decomposition that used them.
"""

from __future__ import annotations

__all__ = ["one_blas_thread"]

_CONTROLLER = []


def one_blas_thread():
    """Context manager: BLAS libraries limited to one thread inside it.

    threadpoolctl's controller is built once (it inspects the loaded
    libraries) and reused."""
    if not _CONTROLLER:
        from threadpoolctl import ThreadpoolController

        _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0].limit(limits=1, user_api="blas")
