"""ROAR's combined driver: the camera car (lane following, lane changes round boxes by its TFmini and
depth camera) behind a leader that tells its position over V2V (real UDP multicast on loopback):
it keeps its gap while the leader is ahead in its lane instead of passing it, changes lanes for a
box once the leader has moved aside, touches nothing, and says every state it went through."""

import numpy as np
import pytest

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
pytest.importorskip("cv2", reason="pip install opencv-python-headless (make setup installs it)")

from roar.autopilot.lane_agent import FOLLOW_GAP_M  # noqa: E402
from roar.tracks import get  # noqa: E402
from roar_sim.runs.combined import combined_race, leader_line, report  # noqa: E402
from roar_sim.world.obstacles import box_course  # noqa: E402

TRACK = "random:31"


def test_the_follower_keeps_its_gap_then_changes_lanes_round_the_box():
    track = get(TRACK)
    boxes = box_course(track, 1)  # in the right lane, 3 m in
    result = combined_race(track, boxes=boxes, distance_m=9.0)  # the follower starts 3 m behind: past the box
    assert result.travelled_m >= 9.0
    assert (result.box_contacts, result.car_contacts, result.wall_contacts) == (0, 0, 0), report(result)
    changes = [(a, b) for _, _, a, b in result.transitions]
    assert ("FOLLOWING", "BEHIND_LEADER") in changes  # caught up with the leader: it keeps the gap
    first_change = next(i for i, (a, b) in enumerate(changes) if b == "CHANGING")
    assert ("FOLLOWING", "BEHIND_LEADER") in changes[:first_change]  # behind the leader before the box
    behind = np.asarray(result.states) == "BEHIND_LEADER"
    gaps = np.asarray(result.gaps_m)[behind]  # from 3 m at the start, closing in
    kept = gaps[np.argmax(gaps <= FOLLOW_GAP_M + 0.1):]  # once closed up
    assert len(kept) >= 50 and np.abs(kept - FOLLOW_GAP_M).max() <= 0.3 and gaps.min() > 1.2  # a second or more
    text = report(result)
    assert "following -> keeping the gap to the leader" in text and "changing lanes" in text


def test_the_leader_s_line_leaves_the_right_lane_round_a_right_lane_box_only():
    track = get(TRACK)
    line = leader_line(track, [(10.0, -0.25), (20.0, 0.25)])
    left = np.sum((line - track.centerline) * track.normals, axis=1)  # [m] left of the centre line
    s = np.concatenate([[0.0], np.cumsum(track.segment_lengths)[:-1]])
    assert np.allclose(left[np.abs(s - 10.0) < 0.5], 0.25)  # beside the right-lane box: the left lane
    assert np.allclose(left[np.abs(s - 20.0) < 0.5], -0.25)  # a left-lane box: it stays right
    step_m = track.segment_lengths[:-1]
    assert np.all(np.abs(np.diff(left)) <= 0.5 * step_m / 1.0 + 1e-9)  # across over a metre, never a jump
