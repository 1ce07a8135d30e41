"""The ``--robots`` flag of the physics CLIs (fidelity, rollout, robot_table): the arm the scene is built with."""

from __future__ import annotations

import argparse


def add_robots_argument(parser: argparse.ArgumentParser) -> None:
    """``--robots NAME``: the arm the scene is built with (one of the robots with a registered skill config).

    The name is checked by :func:`parse_robot` (importing the registry imports robosuite, so not here).
    """
    parser.add_argument("--robots", default="Panda",
                        help="robot arm with a registered skill config: Panda, Sawyer, UR5e, Kinova3 ship "
                             "(tableclean_suite.controllers.robot_configs; default Panda)")


def parse_robot(parser: argparse.ArgumentParser, args) -> str:
    """The checked ``--robots`` name; exits 2 naming the supported robots when it has no skill config."""
    from tableclean_suite.controllers.robot_configs import check_robot

    try:
        return check_robot(args.robots)
    except ValueError as error:
        parser.error(f"--robots: {error}")
