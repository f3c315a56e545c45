"""rpm_cl.heap: freed memory stays in the process for the next allocation."""

from __future__ import annotations

import subprocess
import sys

import pytest

_PROBE = """
import sys
import numpy as np
from rpm_cl.heap import keep_freed_memory

def rss():
    with open("/proc/self/status") as f:
        return next(int(l.split()[1]) for l in f if l.startswith("VmRSS:")) * 1024

kept = keep_freed_memory() if sys.argv[1] == "keep" else None
base = rss()
a = np.ones(64 << 17)  # 64 MiB, touched
del a
print(kept, rss() - base)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc")
def test_freed_memory_stays_in_the_process_only_when_asked():
    """By default glibc unmaps a freed 64 MiB block (the resident memory
    falls back); after keep_freed_memory it stays in the heap (resident)."""

    def run(mode):
        out = subprocess.run(
            [sys.executable, "-c", _PROBE, mode], capture_output=True, text=True, check=True
        ).stdout.split()
        return out[0], int(out[1])

    kept, grown = run("keep")
    if kept != "True":
        pytest.skip("not glibc: mallopt is unavailable")
    _, default = run("default")
    assert grown >= 60 << 20
    assert default < 8 << 20
