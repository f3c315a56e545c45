"""What every imager returns: its points (:class:`Image`) with the range
points they came from and the stage timings (:class:`ImageResult`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .extract.rangepoints import RangePoints

__all__ = ["Image", "ImageResult"]


@dataclass(frozen=True)
class Image:
    """RPM image: one scattering-centre estimate per imaged main RP.

    Attributes
    ----------
    points : ndarray, shape (M, dim)
        (x, y) or (x, y, z), m.
    cluster : ndarray of int, shape (M,)
    score : ndarray, shape (M,)
        The maximised kernel-density value (eq. 6).
    rp_index : ndarray of int, shape (M,)
        Index of the main RP in the RangePoints.
    multipath : ndarray of bool, shape (M,), or None
        Points of clusters that a double bounce between two other objects
        explains (:mod:`rpm_cl.rpm.multipath`), kept because
        ``ImagingParams.multipath`` is "flag"; None where not assessed or
        such points were dropped.
    """

    points: np.ndarray
    cluster: np.ndarray
    score: np.ndarray
    rp_index: np.ndarray
    multipath: np.ndarray | None = None

    def keep(self, mask: np.ndarray) -> Image:
        """The points where ``mask`` (bool, shape (M,)) holds, every column alike."""
        return Image(
            self.points[mask],
            self.cluster[mask],
            self.score[mask],
            self.rp_index[mask],
            None if self.multipath is None else self.multipath[mask],
        )


@dataclass(frozen=True)
class ImageResult:
    """What a method returns: its RPs, the image, and stage timings (s)."""

    method: str
    rps: RangePoints
    image: Image
    timings: dict
    dropped: dict = field(default_factory=dict)
