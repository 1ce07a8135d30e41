"""``python -m benchmarks.render_scene [--task SPEC] [--out PNG]``: render the TableClean scene offscreen.

Uses MuJoCo's EGL backend unless ``MUJOCO_GL`` is already set (it must be set before MuJoCo is
imported).  The default camera, ``tableview``, shows every segment, the dirt, the objects and the
sponge on its stand.  ``--task`` builds another spec's scene (default ``paper``; the default
output is then ``results/images/scene_<task>.png``).  The README's pictures in ``docs/images`` are
copies of these outputs: a reproduction never writes over tracked files.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

from tableclean_suite.bench.startup import add_verbose_flag, apply_verbosity  # noqa: E402

DEFAULT_OUT = Path("results/images/scene.png")
DEFAULT_CAMERA = "tableview"


def render_frame(camera: str = DEFAULT_CAMERA, width: int = 640, height: int = 480, seed: int = 0,
                 object_segment: int = 1, arm_segment: int = 2, task=None, **env_kwargs) -> np.ndarray:
    """An (height, width, 3) uint8 RGB frame of a freshly reset TableClean scene of ``task`` (default ``paper``)."""
    import robosuite

    import tableclean_suite  # noqa: F401  (registers TableClean)

    env = robosuite.make(
        "TableClean",
        task=task,
        robots="Panda",
        object_segment=object_segment,
        arm_segment=arm_segment,
        has_renderer=False,
        has_offscreen_renderer=True,
        use_camera_obs=False,
        seed=seed,
        **env_kwargs,
    )
    try:
        env.reset()
        frame = env.sim.render(width=width, height=height, camera_name=camera)
    finally:
        env.close()
    return np.ascontiguousarray(frame[::-1])  # MuJoCo renders bottom-up


def save_png(frame: np.ndarray, path: Path) -> None:
    """Write an RGB uint8 frame as PNG (matplotlib's writer, a package dependency)."""
    import matplotlib.image

    path.parent.mkdir(parents=True, exist_ok=True)
    matplotlib.image.imsave(path, frame)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.render_scene", description=__doc__.splitlines()[0])
    add_verbose_flag(parser)
    parser.add_argument("--out", type=Path, default=None,
                        help=f"PNG path to write (default {DEFAULT_OUT}, or results/images/scene_<task>.png for another spec)")
    parser.add_argument("--task", default="paper", help="task spec: a registered name or a .json path (default paper)")
    parser.add_argument("--camera", default=DEFAULT_CAMERA, help="camera name (e.g. tableview, frontview)")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    apply_verbosity(args.verbose)
    from tableclean_suite.physics_backend import check_physical_task
    from tableclean_suite.task import TaskModel, get_task_spec

    try:
        spec = get_task_spec(args.task)
        check_physical_task(TaskModel(spec=spec))
    except (ValueError, OSError) as error:
        parser.error(f"--task: {error}")
    if args.out is None:
        args.out = DEFAULT_OUT if spec.name == "paper" else DEFAULT_OUT.with_name(f"scene_{spec.name}.png")
    frame = render_frame(args.camera, args.width, args.height, args.seed, task=spec)
    save_png(frame, args.out)
    print(f"wrote {args.out} ({args.width}x{args.height}, camera {args.camera!r}, MUJOCO_GL={os.environ['MUJOCO_GL']})")


if __name__ == "__main__":
    main()
