"""The IARRC drag race: the IARRC car (its firmware's speed PID, encoder and gyro) down a drag strip
by camera, flat out to the finish, then stopped by its TFmini's range in the stop zone without
touching the end wall, from several top speeds; the gyro holds its heading while the camera is
dark; the strip and the command refuse what they cannot run, in one line."""

import math

import numpy as np
import pytest

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
pytest.importorskip("cv2", reason="pip install opencv-python-headless (make setup installs it)")

from roar.tracks import TrackError, get  # noqa: E402
from roar_sim.runs import drag  # noqa: E402

STRIP = "drag:20"
IN_LANE_M = 0.18  # [m] off the centre line: the car's side (0.15 m out) stays 0.17 m inside the edge lines


@pytest.mark.parametrize("top_speed", [2.0, 4.5])
def test_from_top_speed_it_stops_in_the_stop_zone(top_speed):
    result = drag.drag_race(get(STRIP), top_speed_m_s=top_speed)
    assert result.strip_time_s is not None and result.in_stop_zone, drag.report(result)
    assert result.wall_contacts == 0 and 0.05 < result.nose_gap_m < result.end_m - result.finish_m
    assert result.max_speed_m_s >= 0.9 * min(top_speed, 4.2)  # flat out (the car tops out at ~4.2 m/s)
    assert result.strip_time_s >= result.finish_m / result.max_speed_m_s  # no quicker than physics allows
    assert result.max_lateral_m <= 0.05
    assert result.stopping_m > 0.2 and result.brake_x_m > result.finish_m - 1.0  # braked at the end, not early
    text = drag.report(result)
    assert "time over the strip" in text and "in the stop zone" in text and "largest lateral error" in text


def _blanked():
    return drag.drag_race(get(STRIP), top_speed_m_s=4.5, blank_s=(2.5, 3.0), servo_trim_us=40, bump_deg=12.0)


def test_with_the_camera_dark_at_full_speed_the_gyro_holds_the_lane(monkeypatch):
    """0.5 s of black frames at ~4 m/s, a bump turning the car as they start, and a servo 40 us
    off centre: the gyro's heading hold turns it back, and it stays in its lane; without the hold
    (straight ahead when the lane is unsure) the same run leaves the bump's heading as it is."""
    held = _blanked()
    t = np.asarray(held.t) - held.started_s
    assert held.max_speed_m_s > 3.8 and "HOLD" in held.states
    end_of_dark = np.asarray(held.heading_deg)[np.searchsorted(t, 3.0)]
    assert abs(end_of_dark) < 2.5 and held.max_lateral_m <= IN_LANE_M and held.in_stop_zone, drag.report(held)

    import roar.autopilot.drag as driver

    monkeypatch.setattr(driver, "_wrapped", lambda angle: 0.0)  # no heading error ever: no hold
    drifted = _blanked()
    t = np.asarray(drifted.t) - drifted.started_s
    assert abs(np.asarray(drifted.heading_deg)[np.searchsorted(t, 3.0)]) > 4.0
    assert drifted.max_lateral_m > IN_LANE_M


def test_the_strip_is_a_lane_with_a_wall_at_its_end():
    from roar_sim.world import floor

    track = get("drag:30,width=1.5,stop=8")
    assert track.start_pose == (0.0, 0.0, 0.0)
    (wall,) = track.walls
    assert np.isclose(wall[:, 0].max(), 38.0) and np.isclose(wall[:, 1].max(), 0.75)
    assert floor.colour_at(track, (10.1, 0.0)) == floor.CENTRE_LINE_RGB  # a dash on the strip's axis
    assert floor.colour_at(track, (10.0, 0.65)) == floor.EDGE_LINE_RGB
    assert floor.colour_at(track, (50.0, 6.0)) == floor.ASPHALT_RGB  # the centre line's way back: not painted


@pytest.mark.parametrize("name, message", [
    ("drag:5", "length must be a finite number 10..100 m, got 5"),
    ("drag:forty", "length must be a finite number 10..100 m, got 'forty'"),
    ("drag:nan", "length must be a finite number 10..100 m, got nan"),
    ("drag:40,width=9", "width must be a finite number 0.8..3 m"),
    ("drag:40,stop=nan", "stop must be a finite number 2..20 m, got nan"),
    ("drag:40,lanes=2", "unknown parameter 'lanes'"),
])
def test_a_bad_strip_is_one_line(name, message):
    with pytest.raises(TrackError, match=message):
        get(name)


@pytest.mark.parametrize("argv, message", [
    (["--event", "drag"], "--event drag is the IARRC car's"),
    (["--event", "drag", "--robot", "iarrc", "--track", "oval"], "--event drag runs on a drag strip"),
    (["--event", "drag", "--robot", "iarrc", "--driver", "lane"], "--driver lane is not for the drag race"),
    (["--top-speed", "3"], "--top-speed is the drag race's"),
])
def test_the_command_refuses_what_it_cannot_run(argv, message):
    from roar.cli.sdk import UserError
    from roar_sim.runs import race

    with pytest.raises((UserError, TrackError), match=message):
        race.main(argv)


def test_the_plot_shows_speed_and_heading_along_the_strip(tmp_path):
    result = drag.DragResult(get(STRIP), 20.0, 26.0, 3.0, t=[0.0, 1.0, 2.0], x=[0.0, 10.0, 24.0], y=[0.0, 0.01, 0.0],
                             speed=[0.0, 3.0, 0.0], heading_deg=[0.0, 0.5, 0.0], states=["LANE", "HOLD", "STOPPED"],
                             started_s=0.0, finish_s=1.5, brake_x_m=22.0)
    import matplotlib.pyplot as plt

    fig = drag.plot(result)
    assert [ax.get_ylabel() for ax in fig.axes] == ["speed [m/s]", "heading [deg]"]
    plt.close(fig)
    assert math.isclose(result.nose_gap_m, 26.0 - 24.0 - drag.FRONT_M)
