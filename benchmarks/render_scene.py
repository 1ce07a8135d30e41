"""``python -m benchmarks.render_scene``: entry point of :mod:`tableclean_suite.bench.render_scene` (kept for the checkout)."""

import os

# MuJoCo picks its GL backend when first imported, and importing the package imports it.
os.environ.setdefault("MUJOCO_GL", "egl")

from tableclean_suite.bench.render_scene import main  # noqa: E402

if __name__ == "__main__":
    main()
