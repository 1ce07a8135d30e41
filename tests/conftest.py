"""Test configuration: headless MuJoCo rendering before robosuite is imported."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen rendering without a display (osmesa also works where installed)
