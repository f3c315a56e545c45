"""Shared fixtures: one OpenCL context per test session.

PoCL compiles each program with LLVM (about a second), so programs are built
once here and reused by every test.
"""

import numpy as np
import pytest
from hypothesis import settings

# The property tests draw their examples from a seed derived from each test
# (the same examples every run, as the seeded generators below);
# ``pytest --hypothesis-profile=explore`` draws fresh ones.
settings.register_profile("seeded", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile("seeded")


@pytest.fixture(scope="session")
def cl_env():
    from rpm_cl.cl import create_env

    return create_env()


@pytest.fixture(scope="session")
def dev32(cl_env):
    from rpm_cl.rpm import DeviceRPM

    return DeviceRPM(cl_env, "float32")


@pytest.fixture(scope="session")
def dev64(cl_env):
    from rpm_cl.rpm import DeviceRPM

    if not cl_env.has_double:
        pytest.skip("device has no float64")
    return DeviceRPM(cl_env, "float64")


@pytest.fixture
def rng(request):
    """A fresh generator per test, seeded from the test's name (reproducible,
    different for every test)."""
    import zlib

    return np.random.default_rng(zlib.crc32(request.node.nodeid.encode()))


@pytest.fixture(scope="session")
def p2(tmp_path_factory):
    """The paper's 2-D scene as an input file (``rpm-cl simulate paper-2d``),
    shared by the tests that edit a copy of it."""
    from rpm_cl.cli import main

    path = tmp_path_factory.mktemp("data") / "p2.npz"
    assert main(["simulate", "paper-2d", "-o", str(path), "-q"]) == 0
    return path
