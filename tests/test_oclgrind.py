"""Every kernel runs clean under Oclgrind (out-of-bounds accesses, data races).

Oclgrind is an OpenCL device simulator (pyopencl's ``oclgrind`` extra, in the
test extras).  Its memory checker is always on; ``OCLGRIND_DATA_RACES=1`` adds
the race detector.  Its uninitialised-value plugin is not used: it aborts on
the LLVM ``freeze`` instruction the DAS kernel compiles to, and flags values
inside its own vector ``exp``/``dot`` builtins.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow


def _has_oclgrind() -> bool:
    try:
        import pyopencl as cl
    except ImportError:
        return False
    try:
        return any(p.name == "Oclgrind" for p in cl.get_platforms())
    except cl.Error:  # no platform at all
        return False


@pytest.mark.skipif(not _has_oclgrind(), reason="Oclgrind platform not installed")
def test_kernels_clean_under_oclgrind():
    env = dict(os.environ, OCLGRIND_DATA_RACES="1", PYOPENCL_NO_CACHE="1")
    script = Path(__file__).with_name("oclgrind_kernels.py")
    res = subprocess.run(
        [sys.executable, str(script)],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
        check=False,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    assert res.stdout.strip().endswith("OK")
    bad = [
        ln
        for ln in res.stderr.splitlines()
        if any(w in ln for w in ("Invalid", "race", "OCLGRIND", "out-of-bounds", "error"))
    ]
    assert not bad, "\n".join(bad[:20])
