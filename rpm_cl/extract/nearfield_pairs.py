"""Pair scans of the near-field search (:mod:`rpm_cl.extract.nearfield`):
centres whose waves correlate (aliases, such as +3 and +25 degrees on the
paper's sparse array) re-placed jointly on a grid of pairs.

:class:`_PairPlacement` picks the pairs whose waves correlate above
``PAIR_CORRELATION``, scans every combination of a ``PAIR_GRID`` around one
centre and one around the other
(:meth:`rpm_cl.extract.nearfield_model._Model.scan_pair`), and re-places
every centre alone where a pair moved.
"""

from __future__ import annotations

import numpy as np

from .nearfield_model import _steer
from .nearfield_place import PAIR_CORRELATION, PAIR_GRID


class _PairPlacement:
    """Joint re-placement of correlated pairs of centres.

    A mixin of :class:`rpm_cl.extract.nearfield._Search`, which provides
    ``x``, ``n``, ``k0``, ``spent``, the model (``model``) and the
    one-centre placement (:class:`rpm_cl.extract.nearfield_place._Placement`:
    ``_grid``, :meth:`place_each`).
    """

    def place_two(self, rest, cm, ck):
        """Joint place of two centres near ``cm`` and ``ck`` on PAIR_GRID,
        ``rest`` fixed; (None, None) where the pair stays (the grids' middle)."""
        um, rm = self._grid(cm, PAIR_GRID)
        uk, rk = self._grid(ck, PAIR_GRID)
        c = self.model.scan_pair(rest, um, rm, uk, rk)
        i, j = np.unravel_index(int(np.argmin(c)), c.shape)
        if i == c.shape[0] // 2 and j == c.shape[1] // 2:
            return None, None
        return [float(um[i]), float(rm[i])], [float(uk[j]), float(rk[j])]

    def place_pairs(self, centres):
        """Re-place pairs of centres with correlated waves jointly (aliases)."""
        for _ in range(2):
            changed = False
            for m in range(len(centres)):
                for k in range(m + 1, len(centres)):
                    am = _steer(self.x, centres[m][0], centres[m][1], self.k0)[:, 0]
                    ak = _steer(self.x, centres[k][0], centres[k][1], self.k0)[:, 0]
                    if abs(np.vdot(am, ak)) / self.n < PAIR_CORRELATION:
                        continue
                    if self.spent:
                        return centres
                    rest = [c for i, c in enumerate(centres) if i not in (m, k)]
                    pm, pk = self.place_two(rest, centres[m], centres[k])
                    if pm is not None:
                        changed = True
                        centres[m], centres[k] = pm, pk
            if not changed:
                break
            centres = self.place_each(centres)
        return centres
