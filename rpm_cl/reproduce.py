"""Reproduce the paper's tables: ``rpm-cl reproduce paper-2d``.

Each row images one case with one method at one S/N.  Noisy rows are pooled
over ``trials`` noise realisations (seeds ``seed``, ``seed+1``, ...): counts are
summed, so ``rp_total`` is the number of RPs over all trials.  ``seconds`` is
the median imaging time per trial from s(X, R) to points; programs are built
and every kernel has run once before the clock starts (compile excluded).
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from .data import InputError
from .imaging import METHODS, default_params, timed_run
from .metrics import summary
from .simulate import simulate_preset

__all__ = ["CASES", "PAPER", "ReproRow", "format_table", "pct", "reproduce", "write_json"]

#: The paper's figures (Tables I, II, IV, V and Section V-A4), as fractions;
#: ``*_n`` are the paper's counts of accurate RPs / points where it gives them.
PAPER = {
    ("points-5mm", "kspace-rpm", None): {"rp10": 0.94, "rpm50": 0.67, "rpm100": 1.00},
    ("points-5mm", "kspace-rpm", 20.0): {"rp10": 0.95, "rpm50": 0.71, "rpm100": 0.97},
    ("points-5mm", "kspace-rpm", 10.0): {"rp10": 0.95, "rpm50": 0.50, "rpm100": 0.94},
    ("points-5mm", "kspace-rpm", 0.0): {"rp10": 0.90, "rpm50": 0.35, "rpm100": 0.61},
    ("sparse-20mm", "kspace-rpm", None): {"rp10": 0.87, "rpm50": 0.94},
    ("human-body", "kspace-rpm", None): {"rp10": 0.98, "rpm50": 0.95, "rp10_n": 2248,
                                         "rpm50_n": 1155},
    ("human-body", "kspace-rpm", 20.0): {"rp10": 0.98, "rpm50": 0.95, "rp10_n": 2253,
                                         "rpm50_n": 1170},
}

#: Cases of each reproduction: name -> (preset, S/N list).
CASES = {
    "paper-2d": {
        "points-5mm": ("paper-2d", [None, 20.0, 10.0, 0.0]),
        "sparse-20mm": ("paper-2d-sparse", [None]),
    },
    "paper-3d": {
        "human-body": ("human-body", [None, 20.0]),
    },
}


@dataclass(frozen=True)
class ReproRow:
    """One row of the reproduction (the JSON schema of ``--json``)."""

    case: str
    method: str
    snr_db: float | None
    trials: int
    rp_total: int
    rp_within_10mm: int
    rpm_total: int
    rpm_within_50mm: int
    rpm_within_100mm: int
    seconds: float

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def reproduce(name: str, engine, methods=None, trials: int = 10, seed: int = 0,
              progress=None) -> list[ReproRow]:
    """Run every case of reproduction ``name`` with every method.

    Parameters
    ----------
    name : str
        A key of :data:`CASES`.
    engine : object
        RPM engine (:class:`rpm_cl.rpm.DeviceRPM` or the reference module).
    methods : list of str, optional
        Default: all of :data:`rpm_cl.imaging.METHODS`.
    trials : int
        Noise realisations per noisy row (noise-free rows use 1).
    seed : int
        First noise seed.
    progress : callable, optional
        Called with a short text before each row.
    """
    if name not in CASES:
        raise InputError(f"unknown reproduction {name!r}; choose from {', '.join(CASES)}")
    if trials < 1:
        raise InputError(f"trials must be >= 1, got {trials}")
    methods = list(methods or METHODS)
    rows = []
    for case, (preset_name, snrs) in CASES[name].items():
        for snr in snrs:
            n_trials = 1 if snr is None else trials
            datasets = [simulate_preset(preset_name, snr, seed + t) for t in range(n_trials)]
            for method in methods:
                if progress:
                    progress(f"{case} {method} S/N={'inf' if snr is None else snr}")
                tot = {"rp_total": 0, "rp_within_10mm": 0, "rpm_total": 0,
                       "rpm_within_50mm": 0, "rpm_within_100mm": 0}
                times = []
                for data, preset in datasets:
                    params = default_params(data, **preset.defaults)
                    res, seconds, _ = timed_run(method, data, params, engine)
                    times.append(seconds)
                    s = summary(res.rps, res.image, data.truth)
                    for k in tot:
                        tot[k] += s[k]
                rows.append(ReproRow(case, method, snr, n_trials, seconds=float(np.median(times)),
                                     **tot))
    return rows


def pct(n: int, d: int) -> str:
    """``"95.2% (60/63)"``, or ``"-"`` when ``d`` is 0."""
    return f"{100.0 * n / d:.1f}% ({n}/{d})" if d else "-"


def format_table(rows: list[ReproRow]) -> str:
    """The rows as a text table with the paper's figures beside ours."""
    head = (f"{'case':12s} {'method':11s} {'S/N':>5s} {'RP<=10mm':>20s} {'RPM<=50mm':>20s} "
            f"{'RPM<=100mm':>20s} {'ms':>7s}   paper (RP10/RPM50/RPM100)")
    lines = [head, "-" * len(head)]
    for r in rows:
        snr = "inf" if r.snr_db is None else f"{r.snr_db:g}"
        ref = PAPER.get((r.case, r.method, r.snr_db))
        ref_s = "" if ref is None else " / ".join(
            (f"{100 * ref[k]:.0f}%" + (f" ({ref[k + '_n']})" if k + "_n" in ref else ""))
            if k in ref else "-" for k in ("rp10", "rpm50", "rpm100"))
        lines.append(f"{r.case:12s} {r.method:11s} {snr:>5s} {pct(r.rp_within_10mm, r.rp_total):>20s} "
                     f"{pct(r.rpm_within_50mm, r.rpm_total):>20s} "
                     f"{pct(r.rpm_within_100mm, r.rpm_total):>20s} {1e3 * r.seconds:7.2f}   {ref_s}")
    return "\n".join(lines)


def write_json(path, rows: list[ReproRow], meta: dict) -> None:
    """Write ``{"rows": [...], "meta": {...}}`` atomically."""
    from .data import atomic_write_text

    atomic_write_text(path, json.dumps({"rows": [r.as_dict() for r in rows], "meta": meta},
                                       indent=2))
