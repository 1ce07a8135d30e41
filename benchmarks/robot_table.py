"""``python -m benchmarks.robot_table``: entry point of :mod:`tableclean_suite.bench.robot_table` (kept for the checkout)."""

import os
import sys

# MuJoCo picks its GL backend when first imported, and importing the package imports it.
os.environ.setdefault("MUJOCO_GL", "egl")

from tableclean_suite.bench.robot_table import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
