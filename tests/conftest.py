"""Test configuration: headless MuJoCo rendering before robosuite is imported, and the quick tier.

Markers (registered in pytest.ini): ``slow`` (MuJoCo physics, full-size runs), ``cli`` (a command
line in a new process), ``install`` (pip builds and installs the package), ``ray`` (a local Ray
cluster).  Every test that carries none of them is marked ``quick`` here, so
``python -m pytest -m quick`` is the development tier; ``python -m pytest`` still runs everything.
"""

import os

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen rendering without a display (osmesa also works where installed)

#: Markers that keep a test out of the quick tier.
HEAVY_MARKERS = ("slow", "cli", "install", "ray")


@pytest.hookimpl(tryfirst=True)  # before pytest's own -m selection reads the markers
def pytest_collection_modifyitems(config, items):
    """Mark every test without a heavy marker ``quick``."""
    for item in items:
        if not any(item.get_closest_marker(name) for name in HEAVY_MARKERS):
            item.add_marker(pytest.mark.quick)
