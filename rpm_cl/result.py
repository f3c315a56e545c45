"""What every imager returns (:class:`ImageResult`)."""

from __future__ import annotations

from dataclasses import dataclass, field

from .extract.rangepoints import RangePoints
from .rpm.pipeline import Image

__all__ = ["ImageResult"]


@dataclass(frozen=True)
class ImageResult:
    """What a method returns: its RPs, the image, and stage timings (s)."""

    method: str
    rps: RangePoints
    image: Image
    timings: dict
    dropped: dict = field(default_factory=dict)
