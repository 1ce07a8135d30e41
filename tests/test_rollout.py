"""Rollout videos: the majority policy, argument errors, and a short video written and read back."""

import numpy as np
import pytest

from tableclean_suite.bench import rollout


def test_majority_policy_votes_per_state_and_breaks_ties_low():
    q = np.zeros((3, 24, 4))
    q[0, 0, 2] = q[1, 0, 2] = 1.0  # two runs pick PLACE in state 0
    q[2, 0, 1] = 1.0  # one run picks PICK
    q[0, 1, 3] = 1.0  # state 1: CLEAN once, MOVE (all-zero rows) twice
    policy = rollout.majority_policy(q)
    assert policy[0] == 2 and policy[1] == 0 and policy[2] == 0


@pytest.mark.parametrize(
    "argv",
    [
        ["--video", "out.avi"],
        ["--video", "out.mp4", "--width", "63"],
        ["--video", "out.mp4", "--reward", "r9"],
        ["--video", "out.mp4", "--learner", "dqn"],
        ["--video", "out.mp4", "--object-segment", "3"],
        ["--video", "out.mp4", "--fps", "0"],
        ["--video", "out.mp4", "--still", "still.bmp"],
        [],
    ],
)
def test_bad_arguments_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as exit_info:
        rollout.main(argv)
    assert exit_info.value.code == 2
    assert "error" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.parametrize("suffix", [".mp4"])
def test_rollout_writes_a_readable_video_and_still(tmp_path, suffix):
    import imageio.v2 as imageio

    video, still = tmp_path / f"r{suffix}", tmp_path / "still.png"
    # two actions of the learned policy from state 4 (move, then a pick/clean): short but real physics
    code = rollout.main([
        "--reward", "r4", "--video", str(video), "--still", str(still), "--iterations", "2000", "--runs", "3",
        "--max-actions", "2", "--width", "128", "--height", "96", "--frame-every", "3", "--fps", "10",
    ])
    assert code == 0
    frames = []
    for frame in imageio.get_reader(video, format="FFMPEG"):  # list() would pre-size to len() = inf
        frames.append(frame)
    assert len(frames) > 1
    assert frames[0].shape[:2] == (96, 128)
    assert all(frame.std() > 5 for frame in frames[:: max(1, len(frames) // 5)])  # not blank
    assert not np.array_equal(frames[0], frames[len(frames) // 2])  # the arm moves
    picture = imageio.imread(still)
    assert picture.shape[:2] == (96, 128) and picture.std() > 5
