"""Refinement of the near-field search (:mod:`rpm_cl.extract.nearfield`): each
centre re-placed on local grids around it, the others held.

:class:`_Placement` scans one centre's neighbourhood (``EACH_GRID``, then
``REFINE_STAGES`` finer ``REFINE_GRID`` scans) and sweeps over the centres
until none moves by more than ``MOVE_TOLERANCE`` of a cell; it also holds the
grids and the tolerance that the pair scans (:mod:`rpm_cl.extract.nearfield_pairs`)
and the re-seat cycles (:mod:`rpm_cl.extract.nearfield_pursuit`) use.
"""

from __future__ import annotations

import numpy as np

from .nearfield_map import U_MAX

#: Pairs of centres whose waves correlate above this are re-placed jointly.
PAIR_CORRELATION = 0.2
#: Local grids (points in sin(theta) over +-1 resolution cell, points in R over
#: +-1.5 depths of focus) for re-placing one centre, and a pair of centres.
#: The one-centre scan is then refined REFINE_STAGES times on REFINE_GRID
#: over +-half a step of the grid before (each divides the step by 4: du / 12
#: and 0.09 depths of focus in the end, finer than the former single 21 x 25
#: grid); a pair that moves is followed by the one-centre scans.  The pair
#: grid stays fine: (7, 7), and (7, 7) refined on (3, 3) or (5, 5), lost 1-4
#: points of RPM <= 50 mm on random layouts.
EACH_GRID = (7, 9)
PAIR_GRID = (11, 11)
REFINE_GRID = (5, 5)
REFINE_STAGES = 1
#: A centre counts as moved (another re-placing sweep, another re-seat
#: cycle) when it moves by more than this fraction of a resolution cell in
#: sin(theta) or of a depth of focus in R; smaller moves are kept but are
#: left to the final polish.
MOVE_TOLERANCE = 0.25


class _Placement:
    """Local re-placement of centres on grids in (sin theta, R).

    A mixin of :class:`rpm_cl.extract.nearfield._Search`, which provides
    ``du``, ``dr``, :meth:`dof`, ``spent``, the model (``model``) and the
    grids' unit offsets kept per shape (``_units``).
    """

    def _grid(self, centre, shape, half=None):
        """Grid of ``shape`` points over +-``half`` (sin theta, m) around
        ``centre``; default half widths: a resolution cell, 1.5 depths of focus."""
        u0, r0 = centre
        hu, hr = (self.du, 1.5 * self.dof(r0)) if half is None else half
        unit = self._units.get(shape)
        if unit is None:
            unit = self._units[shape] = [
                g.ravel()
                for g in np.meshgrid(
                    np.linspace(-1, 1, shape[0]), np.linspace(-1, 1, shape[1]), indexing="ij"
                )
            ]
        return np.clip(u0 + hu * unit[0], -U_MAX, U_MAX), np.maximum(r0 + hr * unit[1], self.dr)

    def moved(self, a, b) -> bool:
        """True when centre ``a`` lies more than MOVE_TOLERANCE of a cell from ``b``."""
        return abs(a[0] - b[0]) > MOVE_TOLERANCE * self.du or abs(
            a[1] - b[1]
        ) > MOVE_TOLERANCE * self.dof(b[1])

    def same(self, a, b) -> bool:
        """True when the centre sets ``a`` and ``b`` match one to one within
        MOVE_TOLERANCE (the same solution placed a little differently)."""
        left = list(b)
        for c in a:
            k = next((i for i, d in enumerate(left) if not self.moved(c, d)), None)
            if k is None:
                return False
            left.pop(k)
        return not left

    def place_one(self, others, centre):
        """Best place of one centre near ``centre``, ``others`` fixed: the
        EACH_GRID scan, then REFINE_STAGES scans of REFINE_GRID over +-half a
        step of the grid before (stopping where the budget is spent)."""
        half = np.array([self.du, 1.5 * self.dof(centre[1])])
        shape, best = EACH_GRID, list(centre)
        for stage in range(1 + REFINE_STAGES):
            if stage and self.spent:
                break
            uu, rr = self._grid(best, shape, half)
            i = int(np.argmin(self.model.scan(others, uu, rr)))
            best = [float(uu[i]), float(rr[i])]
            half = half / (np.asarray(shape) - 1)  # half a step of this grid
            shape = REFINE_GRID
        return best

    def place_each(self, centres, sweeps=3):
        """Re-place each centre in turn on a local grid, the others fixed.

        In list order: the new centre last, the others first (placing the new
        one first, from its map peak, lost 3 points of RPM <= 50 mm on random
        layouts).  A centre is not placed again while no other one has moved
        since it was placed (it would stay where it is)."""
        centres = [list(c) for c in centres]
        step, placed, last_move = 0, [-1] * len(centres), [0] * len(centres)
        for _ in range(sweeps):
            moved = False
            for m in range(len(centres)):
                step += 1
                if placed[m] >= 0 and all(
                    last_move[k] < placed[m] for k in range(len(centres)) if k != m
                ):
                    continue
                u0, r0 = centres[m]
                if self.spent:
                    return centres
                best = self.place_one(centres[:m] + centres[m + 1 :], (u0, r0))
                placed[m] = step
                if self.moved(best, (u0, r0)):
                    moved, last_move[m] = True, step
                centres[m] = best
            if not moved:
                break
        return centres
