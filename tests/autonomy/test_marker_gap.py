"""ROAR's first platoon: an ArUco marker on the simulated leader's rear, found by OpenCV's detector
in the follower's camera frame, measures the gap within a few centimetres on a straight, is lost
where ROAR found it lost (too far, in a bend), and the follower then keeps the gap from the V2V
positions instead."""

import numpy as np
import pytest

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
pytest.importorskip("cv2", reason="pip install opencv-python-headless (make setup installs it)")

from roar.tracks import get  # noqa: E402
from roar_sim.runs.marker_gap import sightings, table  # noqa: E402

STRIP = "drag:30"  # a long straight: the leader 12 m down it, the follower up to 4 m behind
BEND_MIDDLE_M = 4.36  # [m] the middle of the oval's first bend (2 m straight + a quarter of 2 pi 1.5 m)


def test_on_a_straight_the_marker_gives_the_distance_within_five_percent_until_too_far():
    samples = sightings(get(STRIP), [0.8, 1.2, 1.6, 2.0, 4.0], [12.0])
    near, far = samples[:-1], samples[-1]
    for s in near:
        assert not s.bend and s.seen_m is not None, s
        assert abs(s.error_m) <= 0.05 * s.true_m, s
    assert far.seen_m is None and far.true_m > 3.5  # about 7 pixels across: too few to read its bits
    rows = table(samples)
    assert any(row.startswith("0-1 m, straight: found 2/2") for row in rows), rows
    assert any("never found" in row for row in rows), rows


def test_in_a_tight_bend_the_leader_leaves_the_camera_s_view():
    (s,) = sightings(get("oval"), [1.5], [BEND_MIDDLE_M])
    assert s.bend and s.seen_m is None


def test_the_follower_keeps_the_gap_by_marker_and_by_v2v_while_it_is_lost():
    from roar.v2v import free_port
    from roar_sim.runs.platoon import GAP_TOLERANCE_M, SETTLE_S, platoon, summarise

    run = platoon(get("oval"), gap_m=1.5, cruise_m_s=1.0, seconds=14, port=free_port(), by_marker=True)
    summary = summarise(run, None)
    assert summary.held and run.contacts == 0, summary
    sources = np.asarray(run.sources)
    steady = np.asarray(run.times_s) > SETTLE_S
    assert 0.4 < (sources[steady] == "marker").mean() < 0.95  # seen on the straights, lost in the bends
    lost = steady & (sources == "v2v")
    assert lost.any() and all(run.marker_gaps_m[i] is None for i in np.flatnonzero(lost))
    gaps = np.asarray(run.gaps_m)
    assert np.all(np.abs(gaps[lost] - run.gap_m) <= GAP_TOLERANCE_M)  # held through the fallback too
    seen = np.array([np.nan if g is None else g for g in run.marker_gaps_m], dtype=float)
    on_straights = steady & (sources == "marker")
    assert np.nanmean(np.abs(seen[on_straights] - gaps[on_straights])) <= 0.05
