"""``tableclean-bench render [--task SPEC] [--out PNG]``: render the TableClean scene offscreen.

MuJoCo's EGL backend unless ``MUJOCO_GL`` is set; the default camera, ``tableview``, shows every
segment, the dirt, the objects and the sponge.  Another ``--task`` writes ``results/images/scene_<task>.png``.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

from tableclean_suite.bench import cli

DEFAULT_OUT = Path("results/images/scene.png")
DEFAULT_CAMERA = "tableview"
#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench render"
#: Frame sizes, pixels per side (larger frames exhaust the GL driver's buffers or the memory).
MIN_PIXELS, MAX_PIXELS = 1, 8192
DEFAULT_WIDTH, DEFAULT_HEIGHT = 640, 480


class UnknownCameraError(ValueError):
    """A camera the scene does not have; the message lists those it has."""


def render_frame(camera: str = DEFAULT_CAMERA, width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT,
                 seed: int = 0, task=None) -> np.ndarray:
    """An (height, width, 3) uint8 RGB frame of a freshly reset TableClean scene of ``task`` (default ``paper``;
    objects on segment 1, the arm at segment 2);
    [`UnknownCameraError`][tableclean_suite.bench.render_scene.UnknownCameraError] listing the scene's cameras."""
    import robosuite

    import tableclean_suite  # noqa: F401  (registers TableClean)

    env = robosuite.make("TableClean", task=task, robots="Panda", object_segment=1, arm_segment=2,
                         has_renderer=False, has_offscreen_renderer=True, use_camera_obs=False, seed=seed)
    try:
        cameras = tuple(env.sim.model.camera_names)
        if camera not in cameras:
            raise UnknownCameraError(f"unknown camera {camera!r}; the scene has {', '.join(cameras)}")
        env.reset()
        frame = env.sim.render(width=width, height=height, camera_name=camera)
    finally:
        env.close()
    return np.ascontiguousarray(frame[::-1])  # MuJoCo renders bottom-up


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line: the shared options of [`cli`][tableclean_suite.bench.cli] and the picture's own."""
    parser = cli.command_parser(prog, __doc__.splitlines()[0])
    cli.add_out_argument(parser, cli.FILE, None, f"PNG path to write ({DEFAULT_OUT} when not given, or "
                         "results/images/scene_<task>.png for another spec)", suffixes=(".png",))
    cli.add_task_argument(parser)
    parser.add_argument("--camera", default=DEFAULT_CAMERA,
                        help=f"camera of the scene, e.g. tableview, frontview, birdview (default {DEFAULT_CAMERA})")
    for side, default in (("width", DEFAULT_WIDTH), ("height", DEFAULT_HEIGHT)):
        parser.add_argument(f"--{side}", type=cli.int_in(MIN_PIXELS, MAX_PIXELS, "pixels"), default=default,
                            help=f"frame {side} in pixels, {MIN_PIXELS}..{MAX_PIXELS} (default {default})")
    cli.add_seed_argument(parser, "the placement noise")
    return parser


def main(argv=None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    from tableclean_suite.bench.fidelity import physical_model

    spec = physical_model(parser, args.task).spec
    if args.out is None:
        args.out = DEFAULT_OUT if spec.name == "paper" else DEFAULT_OUT.with_name(f"scene_{spec.name}.png")
    try:
        frame = render_frame(args.camera, args.width, args.height, args.seed, task=spec)
    except UnknownCameraError as error:
        parser.error(f"--camera: {error}")
    import matplotlib.image

    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    matplotlib.image.imsave(Path(args.out), frame)
    print(f"wrote {args.out} ({args.width}x{args.height}, camera {args.camera!r}, "
          f"MUJOCO_GL={os.environ.get('MUJOCO_GL')})")
    return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("render", "python -m tableclean_suite.bench.render_scene"))
