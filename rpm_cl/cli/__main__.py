"""``python -m rpm_cl.cli``: the ``rpm-cl`` command, as ``python -m rpm_cl``."""

import sys

from .._entry import run

sys.exit(run())
