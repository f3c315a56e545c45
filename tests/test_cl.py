"""OpenCL environment: device choice and build-once caching."""

import pytest

from rpm_cl import cl as clmod


def test_programs_and_kernels_are_built_once(cl_env):
    a = clmod.build_program(cl_env, "circles.cl", {"REAL": "float"})
    b = clmod.build_program(cl_env, "circles.cl", {"REAL": "float"})
    assert a[0] is b[0]
    k1 = clmod.get_kernels(cl_env, "circles.cl", ["intersect_circles"], {"REAL": "float"})
    k2 = clmod.get_kernels(cl_env, "circles.cl", ["intersect_circles"], {"REAL": "float"})
    assert k1["intersect_circles"] is k2["intersect_circles"]
    c = clmod.build_program(cl_env, "score.cl", {"REAL": "float", "DIM": 3})
    d = clmod.build_program(cl_env, "score.cl", {"REAL": "float", "DIM": 2})
    assert c[0] is not d[0]  # other options, other program


def test_device_choice_rules(monkeypatch):
    devices = clmod.list_devices()
    first_cpu = next((d for d in devices if d.kind == "CPU"), devices[0])
    monkeypatch.delenv("PYOPENCL_CTX", raising=False)
    assert clmod.choose_device().spec == first_cpu.spec
    # PYOPENCL_CTX overrides the CPU default (on a one-device machine this
    # still checks that the variable is parsed and honoured)
    last = devices[-1]
    monkeypatch.setenv("PYOPENCL_CTX", last.spec)
    assert clmod.choose_device().spec == last.spec
    monkeypatch.setenv("PYOPENCL_CTX", str(last.platform_index))  # "P" alone: its first device
    assert clmod.choose_device().platform_index == last.platform_index
    assert clmod.choose_device(devices[0].name[:6]).spec == devices[0].spec  # explicit beats env
    monkeypatch.setenv("PYOPENCL_CTX", "99:0")
    with pytest.raises(clmod.NoOpenCLError, match="99:0"):
        clmod.choose_device()


def test_kernel_sources_ship_with_the_package():
    src = clmod.kernel_source("circles.cl")
    assert "__kernel void intersect_circles" in src
    assert "rpm_cl.rpm.reference.intersect_circles" in src  # names its reference
