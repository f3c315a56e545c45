"""``python -m rpm_cl``: the ``rpm-cl`` command."""

import sys

from ._entry import run

sys.exit(run())
