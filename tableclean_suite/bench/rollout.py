"""Watch a learned policy: train on the symbolic model, run the greedy policy with skills in physics.

    tableclean-bench rollout --reward r4 --video out.mp4 --object-segment 1 --arm-segment 1

The policy is the majority vote of ``--runs`` runs' greedy actions (ties: lowest action), trained
on the task model from the chosen start layout and executed from it by the skills; every ``K``-th
control step goes to the video (``.mp4`` through ffmpeg, or ``.gif``) with the symbolic state and
action printed on it.  ``--still`` saves one frame taken while the sponge wipes.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tableclean_suite.bench import cli
from tableclean_suite.task import Action, TaskModel, TaskState

VIDEO_SUFFIXES = (".mp4", ".gif")
#: Frames repeated after each action so the new state can be read.
HOLD_FRAMES = 6
#: The still is taken once this fraction of the arm segment's dirt has been wiped in the first clean.
STILL_WIPED_FRACTION = 0.5


#: Reachable states whose policy action is printed (the rest are elided).
POLICY_PRINT_STATES = 24


def majority_policy(q: np.ndarray) -> np.ndarray:
    """``(S,)`` int: per state, the greedy action most runs agree on (ties towards the lowest action).

    ``q`` is ``(runs, S, A)``; each run's greedy action is the first maximum, as the learners'.
    """
    greedy = np.argmax(q, axis=2)  # (runs, S)
    votes = (greedy[:, :, None] == np.arange(q.shape[2])).sum(axis=0)  # (S, A)
    return np.argmax(votes, axis=1)


class Recorder:
    """Renders the scene every ``filming.frame_every`` control steps, writes annotated frames to ``writer``."""

    def __init__(self, env, writer, filming: Filming):
        from PIL import ImageFont

        self.env, self.writer, self.filming = env, writer, filming
        self.font = ImageFont.load_default(size=max(10, filming.height // 26))
        self.control_steps = 0
        self.frames = 0
        self.state: TaskState | None = None
        self.action: Action | None = None
        self.note = ""
        self.still: np.ndarray | None = None
        self.middle: np.ndarray | None = None
        self._dirt_at_clean_start: float | None = None

    def on_step(self) -> None:
        self.control_steps += 1
        if self.control_steps % self.filming.frame_every == 0:
            frame = self.capture()
            if self.still is None and self.action in (Action.CLEAN, "clean") and self.state is not None:
                segment = self.state.arm
                dirt = float(self.env.dirt_fraction()[segment])
                if self._dirt_at_clean_start is None:
                    self._dirt_at_clean_start = dirt
                if self._dirt_at_clean_start - dirt >= STILL_WIPED_FRACTION * self._dirt_at_clean_start:
                    self.still = frame

    def capture(self, repeat: int = 1) -> np.ndarray:
        from PIL import Image, ImageDraw

        width, height = self.filming.width, self.filming.height
        raw = self.env.sim.render(camera_name=self.filming.camera, width=width, height=height)[::-1]
        image = Image.fromarray(np.ascontiguousarray(raw))
        draw = ImageDraw.Draw(image)
        line_h = self.font.size + 4
        draw.rectangle([0, 0, width, 2 * line_h + 6], fill=(0, 0, 0))
        state = "?" if self.state is None else f"state {self.state.index}: {self.state.name}"
        action = "-" if self.action is None else getattr(self.action, "rule_name", self.action)
        draw.text((6, 3), state, fill=(255, 255, 255), font=self.font)
        draw.text((6, 3 + line_h), f"action: {action}  {self.note}".rstrip(), fill=(255, 220, 120), font=self.font)
        frame = np.asarray(image, dtype=np.uint8)
        for _ in range(repeat):
            self.writer.append_data(frame)
            self.frames += 1
        return frame


def train_policy(learner: str, reward: str, model: TaskModel, runs: int, iterations: int, seed: int) -> np.ndarray:
    """The [`majority_policy`][tableclean_suite.bench.rollout.majority_policy] (``(S,)`` actions) of ``runs``
    runs of ``learner`` on ``reward`` trained on ``model``."""
    from tableclean_suite.learners import train

    return majority_policy(train(learner, reward, runs=runs, iterations=iterations, seed=seed, task=model).q)


@dataclass(frozen=True)
class Filming:
    """How a rollout is filmed.

    Attributes:
        fps: video frames per second (>= 1).
        width, height: frame size in pixels (even).
        frame_every: one frame per this many control steps (>= 1).
        camera: one of `CAMERAS`.
        still: where to save one frame taken while wiping (PNG or JPEG), or None.
    """

    fps: int = 20
    width: int = 480
    height: int = 360
    frame_every: int = 4
    camera: str = "frontview"
    still: Path | None = None


def run_rollout(policy: np.ndarray, start: TaskState, video: Path, filming: Filming = Filming(),
                max_actions: int = 20, seed: int = 0, spec=None, robots: str = "Panda") -> dict:
    """Execute ``policy`` in physics from ``start`` (a state of ``spec``, default ``paper``) with the arm
    ``robots`` (a robot with a registered skill config), writing the video as
    [Filming][tableclean_suite.bench.rollout.Filming] says and printing a line per action; returns a summary dict."""
    import imageio.v2 as imageio

    from tableclean_suite.controllers import SkillController, make_skill_env
    from tableclean_suite.physics_backend import stage

    model = TaskModel(spec=spec)
    env = make_skill_env(has_offscreen_renderer=True, task=model.spec, robots=robots)
    writer_kwargs = {"fps": filming.fps}
    if video.suffix.lower() == ".mp4":
        writer_kwargs.update(codec="libx264", macro_block_size=2, quality=6)
    else:
        writer_kwargs = {"duration": 1000.0 / filming.fps, "loop": 0}
    video.parent.mkdir(parents=True, exist_ok=True)
    summary = {"actions": [], "states": [start.index], "reached_terminal": False, "fault": None}
    with imageio.get_writer(video, **writer_kwargs) as writer:
        recorder = Recorder(env, writer, filming)
        controller = SkillController(env, model, on_step=recorder.on_step)
        stage(env, SkillController(env, model), start, seed=seed)
        state = start
        recorder.state, recorder.note = state, "(start)"
        recorder.capture(repeat=HOLD_FRAMES)
        for _ in range(max_actions):
            action = model.action_name(int(policy[state.index]))
            recorder.action, recorder.note = action, "(executing)"
            result = controller.execute(action)
            summary["actions"].append(action)
            print(f"{state.index:2d} {action:5s} -> "
                  f"{'fault' if result.state_after is None else result.state_after.index}: {result.reason} "
                  f"({result.steps} steps, {result.wall_time:.1f} s)")
            if result.state_after is None:
                summary["fault"] = result.reason
                recorder.note = "(abstraction fault: stopped)"
                recorder.capture(repeat=HOLD_FRAMES)
                break
            state = result.state_after
            summary["states"].append(state.index)
            recorder.state = state
            recorder.note = f"-> {result.outcome.name.lower()}" if result.outcome is not None else ""
            frame = recorder.capture(repeat=HOLD_FRAMES)
            if recorder.middle is None and len(summary["actions"]) >= 4:
                recorder.middle = frame
            if state.is_terminal:
                summary["reached_terminal"] = True
                recorder.note = "every segment clean"
                recorder.capture(repeat=2 * HOLD_FRAMES)
                break
        summary["frames"] = recorder.frames
        summary["control_steps"] = recorder.control_steps
    still = filming.still
    if still is not None:
        from PIL import Image

        frame = recorder.still if recorder.still is not None else recorder.middle
        if frame is None:
            frame = recorder.capture()
        still.parent.mkdir(parents=True, exist_ok=True)
        Image.fromarray(frame).save(still)
    env.close()
    return summary


#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench rollout"
#: Cameras a rollout can be filmed from (robosuite's arena cameras of the TableClean scene).
CAMERAS = ("frontview", "birdview", "agentview", "sideview")
#: Frame sizes a rollout video can have, pixels (even: the video encoders need it).
MIN_PIXELS, MAX_PIXELS = 64, 4096


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line: the shared options of [`cli`][tableclean_suite.bench.cli] and the rollout's own."""
    from tableclean_suite.learners import learner_names
    from tableclean_suite.rewards import reward_pattern_names

    pixels = cli.number_type(int, lambda v: MIN_PIXELS <= v <= MAX_PIXELS and v % 2 == 0,
                             f"an even number of pixels in [{MIN_PIXELS}, {MAX_PIXELS}]")
    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    parser.add_argument("--reward", default="r4", choices=reward_pattern_names(),
                        help="reward pattern (default r4)")
    cli.add_out_argument(parser, cli.FILE, None, "output video, .mp4 or .gif (required unless --task is given: "
                         "then results/rollout_<task>.mp4)", flags=("--out", "--video"), suffixes=VIDEO_SUFFIXES)
    cli.add_task_argument(parser, default=None,
                          help="task spec: a registered name or a .json path (default paper); with no --still, the "
                               "still goes to results/images/rollout_<task>.png")
    parser.add_argument("--learner", default="q_learning", choices=learner_names(), metavar="NAME",
                        help="learner (default q_learning)")
    parser.add_argument("--object-segment", type=int, default=1,
                        help="start: every object on this segment (1..N, default 1)")
    parser.add_argument("--arm-segment", type=int, default=1, help="start: arm over this segment (1..N, default 1)")
    cli.add_iterations_argument(parser, 3000, "training iterations per run")
    cli.add_runs_argument(parser, 5, "training runs voting on the policy")
    cli.add_seed_argument(parser, "the training runs and the placement noise")
    parser.add_argument("--fps", type=cli.positive_int, default=20, help="video frames per second (default 20)")
    parser.add_argument("--width", type=pixels, default=480, help="frame width in pixels, even (default 480)")
    parser.add_argument("--height", type=pixels, default=360, help="frame height in pixels, even (default 360)")
    parser.add_argument("--frame-every", type=cli.positive_int, default=4,
                        help="one frame per K control steps (default 4)")
    parser.add_argument("--max-actions", type=cli.positive_int, default=20,
                        help="stop after this many actions (default 20)")
    parser.add_argument("--camera", default=CAMERAS[0], choices=CAMERAS, help=f"camera (default {CAMERAS[0]})")
    parser.add_argument("--still", type=cli.output_path(cli.FILE, (".png", ".jpg", ".jpeg")),
                        help="also save one frame (PNG) taken while wiping")
    cli.add_robots_argument(parser)
    return parser


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    from tableclean_suite.bench.fidelity import physical_model

    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    model = physical_model(parser, args.task)
    spec = model.spec
    if args.out is None:
        if args.task is None:
            parser.error("--video (or --out) is required (or give --task to write results/rollout_<task>.mp4)")
        args.out = f"results/rollout_{spec.name}.mp4"
        if args.still is None:
            args.still = f"results/images/rollout_{spec.name}.png"
    robot = cli.parse_robot(parser, args)  # before training: exits 2 naming the supported robots
    for flag, value in (("--object-segment", args.object_segment), ("--arm-segment", args.arm_segment)):
        if not 1 <= value <= spec.segments:
            parser.error(f"{flag} must be a segment number in 1..{spec.segments} for task {spec.name!r}, got {value}")
    video, still = Path(args.out), Path(args.still) if args.still else None
    try:  # before training: the video is written last
        import imageio.v2  # noqa: F401
    except ImportError as error:
        parser.error(f"--video needs the video extra (pip install 'tableclean_suite[video]'): {error}")
    start = TaskState((False,) * spec.segments, (args.object_segment - 1,) * spec.n_objects, args.arm_segment - 1)
    started = time.perf_counter()
    policy = train_policy(args.learner, args.reward, TaskModel(start_state=start, spec=spec), args.runs,
                          args.iterations, args.seed)
    reachable = model.reachable_states([start])
    print(f"policy from {args.runs} run(s) x {args.iterations} iterations ({args.learner}, {args.reward}) on "
          f"{spec.name}: "
          + ", ".join(f"{s.index}:{model.action_name(int(policy[s.index]))}"
                      for s in reachable[:POLICY_PRINT_STATES] if not s.is_terminal)
          + (" ..." if len(reachable) > POLICY_PRINT_STATES else ""))
    filming = Filming(args.fps, args.width, args.height, args.frame_every, args.camera, still)
    summary = run_rollout(policy, start, video, filming, args.max_actions, args.seed, spec=spec, robots=robot)
    outcome = "reached the terminal state" if summary["reached_terminal"] else (
        f"stopped by a fault ({summary['fault']})" if summary["fault"]
        else f"did not finish in {args.max_actions} actions")
    print(f"{len(summary['actions'])} actions, {outcome}; wrote {video} ({summary['frames']} frames, "
          f"{summary['control_steps']} control steps){f' and {still}' if still else ''} in "
          f"{time.perf_counter() - started:.0f} s")
    return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("rollout", "python -m tableclean_suite.bench.rollout"))
