"""Racing other cars (roar race --opponents): the ego senses them by its lidar alone, follows
where it cannot pass, passes where it can, and every car-to-car contact names the car that
caused it. Longer sweeps belong in `make bench`."""

import math
import subprocess
import sys
from collections import deque

import pytest

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

from roar.tracks import get  # noqa: E402
from roar_sim.runs.head_to_head import Rival, attribute, head_to_head, report  # noqa: E402


def test_the_lidar_finds_the_car_ahead_and_not_the_walls():
    from roar.racing.detection import CarDetector
    from roar_sim.runs.fleet import Fleet
    from roar_sim.sensors.lidar import Lidar
    from roar_sim.world.scene import world_map

    track = get("oval")
    with Fleet(track, count=2, gap_m=1.5) as fleet:
        ahead, ego = fleet.cars
        fleet.run(0.1)
        scan = Lidar(ego.plant, seed=1).scan(0.1, [ahead.plant])
        o = ego.observe()
        mx, my, myaw = ego.plant.lidar_mount()
        sensor = (o.x + mx * math.cos(o.yaw) - my * math.sin(o.yaw), o.y + mx * math.sin(o.yaw) + my * math.cos(o.yaw),
                  o.yaw + myaw)
        found = CarDetector(world_map(track)).detect(scan, sensor)
        cx, cy = ahead.plant.footprint()[:2]
    assert len(found) == 1, found
    assert math.hypot(found[0].x - cx, found[0].y - cy) < 0.2


def test_on_a_track_too_narrow_to_pass_the_ego_follows_without_touching():
    result = head_to_head(get("oval"), [Rival(pace=0.8)], laps=1)
    assert len(result.cars[0].lap_times_s) == 1, report(result)
    assert not result.contacts and result.cars[0].wall_contacts == 0, report(result)
    assert result.passes_started == 0 and result.modes.count("follow") > len(result.modes) / 2
    assert min(result.gaps_ahead_m) > 0.3  # bumper to bumper [m], never closer


def test_the_ego_passes_a_slower_car_on_a_wide_circuit():
    result = head_to_head(get("circuit:3"), [Rival(pace=0.8)], laps=1, timeout_s=25.0)
    assert result.overtakes >= 1, report(result) + "\n" + "\n".join(f"{t:.2f} {e}" for t, e in result.events)
    assert not result.caused_by(0) and result.cars[0].wall_contacts == 0, report(result)
    assert result.order()[0] == 0  # it leads at the end


def test_a_contact_is_laid_on_the_car_that_moved_across_or_else_the_one_behind_closing():
    track = get("course")
    history = deque(maxlen=26)
    for k in range(26):  # car 0 drifts 0.3 m left toward car 1 over 0.5 s; car 1 holds its line
        history.append([(5.0 + 0.05 * k, -0.3 + 0.012 * k, 2.0), (5.2 + 0.05 * k, 0.15, 2.0)])
    contact = attribute(track, history, [5.0, 5.2], 0, 1, 1.0)
    assert contact.caused_by == 0 and "sideways" in contact.why
    history = deque([[(5.0, 0.0, 2.5), (5.5, 0.0, 2.0)]] * 26, maxlen=26)  # in line, car 0 behind and faster
    assert attribute(track, history, [5.0, 5.5], 0, 1, 1.0).caused_by == 0
    history = deque([[(5.0, 0.0, 2.0), (5.5, 0.0, 2.5)]] * 26, maxlen=26)  # the one ahead is faster: nobody
    assert attribute(track, history, [5.0, 5.5], 0, 1, 1.0).caused_by is None


class CountingDriver:
    """A user's opponent: the built-in line follower, counting its steps."""

    steps = 0

    def __init__(self, track, line, model, period_s, pace):
        from roar.autopilot.race_agent import race_agent

        self.agent = race_agent(line, model, period_s, margin=pace)

    def setup(self):
        self.agent.setup()

    def step(self, observation):
        CountingDriver.steps += 1
        return self.agent.step(observation)


def test_a_race_on_the_record_holds_every_cars_channels_and_what_the_ego_sensed(tmp_path):
    """--log with opponents: the ego's channels as a race alone records them, its scan and the
    cars it tracked, each opponent's own channels, the standings; read back by the mcap library."""
    pytest.importorskip("mcap", reason="pip install mcap (make setup installs it)")
    from roar.replay import messages, read_log

    path = tmp_path / "race.mcap"
    result = head_to_head(get("oval"), [Rival(pace=0.8)], laps=1, timeout_s=3.0, log=path)
    periods = len(result.times_s)
    counts = {topic: c.count for topic, c in read_log(path).channels.items()}
    for topic in ("/car/state", "/sim/firmware", "/lidar", "/racing/tracked", "/autopilot/state",
                  "/race/car_1/pose", "/race/car_1/firmware", "/race/standings"):
        assert counts.get(topic) == periods, (topic, counts)
    assert counts["/control"] >= periods
    truth, tracked = {}, {}
    for topic, t, msg in messages(path, ["/race/car_1/pose", "/racing/tracked"]):
        if topic == "/racing/tracked":
            tracked[t] = [(p.position.x, p.position.y) for p in msg.poses]
        else:
            truth[t] = (msg.pose.position.x, msg.pose.position.y)
    near = [t for t, seen in tracked.items() if any(math.dist(xy, truth[t]) < 0.35 for xy in seen)]
    assert len(near) > periods / 2  # the car ahead, tracked where it truly was, most of the time
    last = list(messages(path, ["/race/standings"]))[-1][2]
    assert last["positions"] == result.positions[-1] and len(last["raced_m"]) == 2


def test_a_users_driver_class_races_as_an_opponent():
    CountingDriver.steps = 0
    result = head_to_head(get("oval"), [Rival(pace=0.6, driver=CountingDriver)], laps=1, timeout_s=4.0)
    assert CountingDriver.steps == len(result.times_s)
    assert result.cars[1].travelled_m > 5.0  # it drove


def test_an_iarrc_car_races_as_an_opponent_and_waits_behind_a_slower_car():
    """The IARRC car (its own tasks and PID, driven by setpoints) joins the race; faster than the
    ESC car ahead of it on the grid, it keeps its gap behind it instead of driving into it."""
    track = get("random:1,width=2.2")
    result = head_to_head(track, [Rival(pace=0.9, robot="iarrc"), Rival(pace=0.5)], laps=1, timeout_s=12.0)
    assert result.cars[1].travelled_m > 15.0, report(result)  # it drove (its setpoints reached its PID)
    assert not [c for c in result.contacts if c.cars == (1, 2)], report(result)
    assert all(r.wall_contacts == 0 for r in result.cars[1:]), report(result)


@pytest.mark.parametrize("args, words", [
    (["--opponents", "6"], "--opponents must be 1..5"),
    (["--opponents", "1", "--opponent-pace", "0"], "--opponent-pace must be 0.3..1"),
    (["--opponents", "1", "--opponent-pace", "nan"], "--opponent-pace must be 0.3..1"),
    (["--opponent-line", "defensive"], "needs --opponents"),
    (["--opponents", "1", "--track", "figure-eight"], "crosses itself"),
    (["--opponents", "5", "--track", "oval"], "a grid of 6 cars"),
    (["--opponents", "1", "--opponent-driver", "nosuch:Driver"], "cannot import 'nosuch'"),
    (["--opponents", "2", "--opponent-robot", "esc,junior"], "--opponent-robot: 'junior' cannot race here"),
    (["--opponent-robot", "iarrc"], "needs --opponents"),
])
def test_bad_race_options_fail_in_one_line(args, words):
    run = subprocess.run([sys.executable, "-m", "roar.cli", "race", *args], capture_output=True, text=True, timeout=120)
    lines = run.stderr.strip().splitlines()
    assert run.returncode == 1 and len(lines) == 1 and words in lines[0], run.stderr
