"""Hostile and corrupted inputs through the CLI: a fixed, seeded subset of the
fuzz campaign (``benchmarks/fuzz.py``, whose mutations these are), one to
three cases per family.  No case may hang, be stopped at the memory cap, print
a traceback, bring a marked byte from a file outside its input into its output
(or exit 0 on data that live only outside the input), or change an input file.
The full campaign, with the garbage, slow-refusal and slow-accept checks that
need clean reference runs, is ``python benchmarks/fuzz.py [--quick]``."""

import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import fuzz

SEED = 24
TIMEOUT = 10.0  # s: a clean run takes about 1.5 s, a batch of two frames about 4 s
MEM_CAP = 2 << 30  # bytes: the inputs are below 1 MB
BOMB = 64 << 20  # bytes a zip bomb inflates

# (family, mutation, command); None: the mutation picks it (view for results)
FAST = [
    ("bytes", "few", "image"),
    ("bytes", "many", "params"),
    ("truncate", "half", "image"),
    ("truncate", "tiny", "das"),
    ("dtypes", "data-str", "image"),
    ("dtypes", "truth-scene-deep", "params"),
    ("dtypes", "das-axis-overflow", None),
    ("extreme", "one-neg-3.6e64", "image"),
    ("extreme", "fc-1e30", "image"),
    ("extreme", "one-nan", "das"),
    ("units", "f-kHz", "params"),
    ("units", "x-mm", "image"),
    ("zipbomb", "declared", "image"),
    ("zipbomb", "many-members", "params"),
    ("hdf5", "external-scene", "image"),
    ("hdf5", "extlink-x", "params"),
    ("hdf5", "virtual-x", "image"),
    ("hdf5", "group-data", "image"),
    ("special", "dev-zero", "image"),
    ("special", "fifo", "params"),
    ("special", "directory", "image"),
    ("outputs", "same", "image"),
    ("outputs", "symlink", "das"),
    ("outputs", "hardlink", "params"),
    ("sigint", "image", None),
    ("sigint", "params", None),
    ("config", "deep-arrays", "params"),
    ("config", "nan", "image"),
]
SLOW = [
    ("zipbomb", "unused", "image"),
    ("zipbomb", "signal", "das"),
    ("hdf5", "chunked-1e9-x", "image"),
    ("hdf5", "chunked-1e9-unused", "params"),
    ("hdf5", "external-data", "das"),
    ("special", "config-fifo", "image"),
    ("special", "dev-urandom", "params"),
    ("extreme", "spikes-3x1e3", "batch"),
    ("bytes", "few", "batch"),
    ("outputs", "same", "batch"),
    ("sigint", "batch", None),
]


def _run(root, cases):
    root = Path(root)
    bases = fuzz.Bases(root, BOMB, SEED)
    ref = {"marker": bases.marker, "truth": bases.truth, "base_rss": {}, "clean": {}}
    made = [
        fuzz.make_case(i, fam, mut, root, bases, np.random.default_rng([SEED, i]), cmd)
        for i, (fam, mut, cmd) in enumerate(cases)
    ]
    with ThreadPoolExecutor(2) as ex:
        return list(ex.map(lambda c: fuzz.run_case(c, ref, TIMEOUT, MEM_CAP), made))


@pytest.fixture(scope="module")
def fast(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("fuzz"), FAST)


BAD = ("overwritten", "outside-read", "hang", "memory", "traceback")


def _check(recs):
    bad = [
        f"{r['family']}/{r['mutation']}: {r['cli']} -> {'+'.join(r['flags'])} "
        f"(rc {r['rc']}, {r['wall']} s, {r['rss_mb']} MB): {r['stderr'][-300:].strip()}"
        for r in recs
        if set(r["flags"]) & set(BAD)
    ]
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("family", sorted({f for f, _, _ in FAST}))
def test_family_holds(fast, family):
    recs = [r for r in fast if r["family"] == family]
    assert recs
    _check(recs)


def test_outcomes_are_told_apart(fast):
    """The classification itself: a clean refusal and an acceptance are seen
    as such (a subset where nothing is refused or accepted checks nothing)."""
    outcomes = {r["outcome"] for r in fast}
    assert {"refused", "accepted"} <= outcomes | {o for r in fast for o in r["flags"]}


@pytest.mark.slow
def test_heavy_cases_hold(tmp_path):
    _check(_run(tmp_path, SLOW))


def test_a_sigint_before_the_handlers_is_told_from_a_traceback_of_ours():
    """The campaign's ``startup`` flag: a KeyboardInterrupt in Python's own
    start-up or in the module-level imports of the entry modules (death by
    SIGINT with nothing said, too) is outside reach; one raised inside a
    function of rpm_cl is a traceback of ours."""
    tb = (
        'Traceback (most recent call last):\n  File "{}", line 3, in {}\n    x\nKeyboardInterrupt\n'
    )
    assert fuzz.before_handlers(tb.format("<frozen importlib._bootstrap>", "_load"), 1)
    assert fuzz.before_handlers(tb.format("/site/rpm_cl/_entry.py", "<module>"), -2)
    assert fuzz.before_handlers("", -2)
    assert not fuzz.before_handlers(tb.format("/site/rpm_cl/_entry.py", "run"), 1)
    assert not fuzz.before_handlers(tb.format("/site/rpm_cl/cli/commands.py", "main"), 1)
    assert not fuzz.before_handlers("rpm-cl: interrupted\n", 130)
    assert not fuzz.before_handlers(tb.format("<frozen importlib._bootstrap>", "_load"), 2)
