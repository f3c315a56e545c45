"""What a decomposition hands to the RP extraction: the decomposed signals
(:class:`Cluster`) and the k-space map they came from
(:class:`Decomposition`).  Both decompositions, the k-space one
(:mod:`rpm_cl.extract.kspace`) and the near-field one (:mod:`rpm_cl.extract.nearfield`),
return them, so neither imports the other for its types.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Cluster", "Decomposition"]


@dataclass(frozen=True)
class Cluster:
    """One decomposed signal.

    Attributes
    ----------
    k : ndarray, shape (n_k_axes,)
        Centre wavenumber(s) (k_x[, k_z]), rad/m.
    r_centre : float
        Centre range R~, m.
    r_slice : slice
        Range gates kept (indices into the data's range axis).
    signal : ndarray, complex, shape (nx, n_gates) or (nx, nz, n_gates)
        The decomposed signal s~(X[,Z], R + offset) over ``r_slice``: range
        gate g of antenna X holds range ``range[g] + offset[X]``.
    peak : float
        |S| at the centre (of the dechirped spectrum at focused gates,
        module notes, step 2).
    offset : ndarray, shape (nx,) or (nx, nz)
        Range offset of each antenna's decomposed profile, m (0 without
        alignment).
    direction : ndarray, shape (n_k_axes,)
        Range slopes u = dR/dX (and dR/dZ) used for the alignment, i.e. minus
        the direction cosines of the cluster's targets (0 without alignment).
    focus : ndarray, shape (n_k_axes,), or None
        Factor of the Fresnel part of the focus wavefront along each array
        axis (module notes, step 6): 1 is a point at ``r_centre``, ``r / (r +
        rho)`` a convex surface of curvature radius ``rho``; None where the
        cluster is not focused.
    """

    k: np.ndarray
    r_centre: float
    r_slice: slice
    signal: np.ndarray
    peak: float
    offset: np.ndarray
    direction: np.ndarray
    focus: np.ndarray | None = None


@dataclass(frozen=True)
class Decomposition:
    """Result of :func:`rpm_cl.extract.kspace.decompose` (and of the near-field
    decomposition, :mod:`rpm_cl.extract.nearfield`).

    Attributes
    ----------
    k_axes : tuple of ndarray
        k_x (and k_z) sample grids of the padded FFT, rad/m, FFT order.
    magnitude : ndarray, shape (nkx[, nkz], n)
        |S(k, R)| over the n range gates from ``gate0`` on (those the
        decomposition searched, from the first to the last; 0 at gates
        between them it skipped, and at every gate beyond them); at gates
        where detection is dechirped (focused arrays, module notes, step 2),
        that of the dechirped data.  :meth:`full_magnitude` spreads it over
        every gate.
    clusters : tuple of Cluster
        Strongest first.
    gate0 : int
        The range gate of ``magnitude``'s first sample.
    near_field : bool
        The clusters are the near-field decomposition's
        (:mod:`rpm_cl.extract.nearfield`): fitted spherical waves, whose phase is the
        model's rather than measured.
    """

    k_axes: tuple
    magnitude: np.ndarray
    clusters: tuple
    gate0: int = 0
    near_field: bool = False

    def full_magnitude(self, nr: int) -> np.ndarray:
        """``magnitude`` on all ``nr`` range gates of the data (0 where it
        was not computed), shape (nkx[, nkz], nr)."""
        mag = self.magnitude
        out = np.zeros(mag.shape[:-1] + (nr,), mag.dtype)
        n = max(0, min(mag.shape[-1], nr - self.gate0))
        out[..., self.gate0 : self.gate0 + n] = mag[..., :n]
        return out
