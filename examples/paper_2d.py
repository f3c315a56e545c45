"""Image the paper's 2-D scene from Python: simulate, decompose, RPM, score.

Run: python examples/paper_2d.py
"""

import numpy as np

from rpm_cl.cl import create_env
from rpm_cl.imaging import run_method
from rpm_cl.metrics import summary
from rpm_cl.rpm import DeviceRPM
from rpm_cl.rpm.params import default_params
from rpm_cl.simulate import simulate_preset


def main(snr_db=20.0, seed=0):
    env = create_env()  # first CPU device, or PYOPENCL_CTX
    engine = DeviceRPM(env, "float32")
    # the paper's S/N definition: noise at the receiver's sample rate (rpm_cl.simulate)
    data, preset = simulate_preset("paper-2d", snr_db, seed, noise="receiver")
    params = default_params(data, **preset.defaults)
    result = run_method("kspace-rpm", data, params, engine)
    print(
        f"{len(result.rps)} RPs in {len(np.unique(result.rps.cluster))} clusters, "
        f"{len(result.image.points)} points on {env.name}"
    )
    print(summary(result.rps, result.image, data.truth))
    return result


if __name__ == "__main__":
    main()
