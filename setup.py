"""Packaging for tableclean_suite.

Version pins, and why:
- robosuite 1.5.x: the environment subclasses its ``ManipulationEnv`` and uses
  its composite-controller configs (introduced in 1.5).
- mujoco >= 3.3, < 3.10: robosuite 1.5.2 needs mujoco >= 3.3; mujoco 3.10 changed
  ``mj_fullM``, 3.11 removed ``MjData.qM`` (both used by robosuite's OSC), and
  3.12+ (and 4.x) fail robosuite's ``get_joint_qpos_addr`` with an AssertionError.
- numba < 0.69: the batched tabular learners are compiled with it (robosuite needs it too); the
  training loop borrows its array arguments (views without numba's reference counts,
  ``learners/kernel.py``: ``borrowed``), numba internals checked with 0.68.1, the newest release.
- wrapt: its post-import hook registers ``TableClean`` when robosuite is imported, so the
  symbolic parts start without importing robosuite.
"""

from setuptools import find_packages, setup

setup(
    name="tableclean_suite",
    version="0.2.0",
    description=(
        "A robosuite plugin and benchmark suite for task-level RL in table cleaning: N segments x M objects, "
        "tabular learners with reduced state spaces and reward patterns, skills in MuJoCo physics."
    ),
    long_description=open("README.md", encoding="utf-8").read(),
    long_description_content_type="text/markdown",
    python_requires=">=3.10",
    packages=find_packages(include=["tableclean_suite", "tableclean_suite.*"]),  # tableclean_suite.bench too
    # The benchmark commands ship with the package (its paper numbers are Python data, no data files):
    # tableclean-bench COMMAND (bare: the paper's run).
    # tableclean_bench: the console script's entry, outside the package (Ctrl-C during the package's import)
    py_modules=["tableclean_bench"],
    entry_points={"console_scripts": ["tableclean-bench = tableclean_bench:main"]},
    install_requires=[
        "robosuite>=1.5,<1.6",
        "mujoco>=3.3,<3.10",
        "numpy",
        "numba<0.69",
        "pandas",
        "matplotlib",
        "gymnasium>=1.0",
        "tqdm",
        "scipy",  # statistics (intervals, fits); robosuite's OSC uses it too
        "wrapt",  # post-import hook: TableClean registers when robosuite is imported, not before
        "psutil",  # available memory for the resource guard (tableclean_suite.resources); workers die with their parent
    ],
    extras_require={
        # dev: everything the test suite exercises (pytest-xdist: pytest.ini runs one worker per core;
        # wheel: the install test builds offline; optuna: tuning; h5py: demonstration datasets; ray: the
        # executor tests start a local Ray on loopback; psutil: the memory check;
        # the docs extra: tests/test_docs.py builds the site)
        "dev": ["pytest", "pytest-xdist", "wheel", "optuna", "h5py", "ray", "psutil",
                "mkdocs", "mkdocs-material", "mkdocstrings[python]",
                "lifelines",  # an independent Kaplan-Meier the learning-time tests compare scipy's with
                "pddl", "unified-planning", "up-pyperplan"],  # the PDDL export's tests parse it and solve with pyperplan
        "docs": ["mkdocs", "mkdocs-material", "mkdocstrings[python]"],  # mkdocs serve / mkdocs build --strict
        "video": ["imageio", "imageio-ffmpeg", "moviepy"],  # moviepy: Gymnasium's RecordVideo
        "tune": ["optuna"],  # tableclean-bench tune
        "demos": ["h5py"],  # tableclean-bench demos, tableclean_suite.demos
        "cluster": ["ray"],  # --executor ray: the harness's cells on a Ray cluster
        "planning": ["unified-planning", "up-pyperplan", "up-fast-downward"],  # tableclean-bench pddl's planners
        "sb3": ["stable-baselines3", "sb3-contrib"],  # optional: MaskablePPO on the Gym envs (pulls torch)
    },
)
