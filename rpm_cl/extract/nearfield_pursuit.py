"""Matching pursuit of the near-field search (:mod:`rpm_cl.extract.nearfield`):
centres added one at a time, each new one chosen among the map's candidates
by the residual its fit leaves, and the solution re-seated.

:class:`_Pursuit` adds centres while each lowers the residual energy by
``MIN_GAIN_DB`` or more, and after each addition takes every centre out in
turn and searches its place again (``RESEAT_CYCLES`` passes at most, none
once the residual is at the noise floor).
"""

from __future__ import annotations

import numpy as np

#: A new centre must lower the residual energy by this much, dB.
MIN_GAIN_DB = 0.5
#: Passes that take each centre out and search its place again.
RESEAT_CYCLES = 2


class _Pursuit:
    """The search's outer loop: centres added and re-seated.

    A mixin of :class:`rpm_cl.extract.nearfield._Search`, which provides the
    limits (``spent``, :meth:`max_centres`, :meth:`floor`), ``du``,
    :meth:`dof`, the model (``model``), the answers kept per question
    (``_memo``), the candidates (:class:`rpm_cl.extract.nearfield_map._FocusMap`)
    and the placements (:class:`rpm_cl.extract.nearfield_place._Placement`,
    :class:`rpm_cl.extract.nearfield_pairs._PairPlacement`).
    """

    def best_with(self, fixed, exclude=None):
        """Best candidate added to ``fixed``, all centres re-placed:
        (centres, cost, peak), or None without candidates.  Candidates
        within a resolution cell and a depth of focus of ``exclude`` are not
        tried (re-seating: the centre taken out, whose solution is known).
        Remembered per question (the re-seat cycles ask some again)."""
        key = (tuple(tuple(c) for c in fixed), None if exclude is None else tuple(exclude))
        if key not in self._memo:
            self._memo[key] = self._best_with(fixed, exclude)
        best = self._memo[key]
        return None if best is None else ([list(c) for c in best[0]], best[1], best[2])

    def _best_with(self, fixed, exclude):
        best = None
        for u0, r0, value in self.candidates(fixed):
            if self.spent:
                break
            if exclude is not None and (
                abs(u0 - exclude[0]) <= self.du and abs(r0 - exclude[1]) <= self.dof(exclude[1])
            ):
                continue
            trial = self.place_each(fixed + [[u0, r0]])
            if len(trial) > 1:
                trial = self.place_pairs(trial)
            c = self.model.cost(trial)
            if best is None or c < best[1]:
                best = (trial, c, value)
        return best

    def run(self):
        """Centres [(u, r)] and their map peaks."""
        centres, peaks = [], []
        cost = self.model.energy
        for _ in range(self.max_centres()):
            if self.spent:
                break
            best = self.best_with(centres)
            if best is None:
                break
            if centres and 10 * np.log10(cost / max(best[1], 1e-300)) < MIN_GAIN_DB:
                break
            centres, cost = best[0], best[1]
            peaks.append(best[2])
            # re-seat: a centre chosen before the others were known may sit
            # between targets; take each out in turn and search its place again
            # (not once the residual is down to the noise: nothing is left
            # that another placement could explain)
            cycles = RESEAT_CYCLES if len(centres) > 1 and cost > self.floor(len(centres)) else 0
            for _ in range(cycles):
                changed = False
                for m in range(len(centres)):
                    if self.spent:
                        break
                    alt = self.best_with(centres[:m] + centres[m + 1 :], exclude=centres[m])
                    if alt is not None and alt[1] < cost * (1 - 1e-3):
                        # a better placement of the same centres is kept; only
                        # a different solution asks for another cycle
                        changed |= not self.same(alt[0], centres)
                        centres, cost = alt[0], alt[1]
                        peaks = peaks[:m] + peaks[m + 1 :] + [alt[2]]
                if not changed:
                    break
        return centres, peaks
