"""`make run` today: the firmware core driven by a scripted host session, printed and plotted."""


from roar.cli.sdk import run_command
from roar.protocol import spec
from roar_sim.runs import scripted_drive
from roar_sim.core.library import BrakePhase, ControlSource


def segment_samples(trace, label):
    starts = [t for t, _ in trace.marks] + [float("inf")]
    i = [lbl for _, lbl in trace.marks].index(label)
    return [s for s in trace.samples if starts[i] <= s.t_us < starts[i + 1]]


def test_script_shows_every_safety_behaviour():
    trace = scripted_drive.run()
    labels = [lbl for _, lbl in trace.marks]
    boot = segment_samples(trace, labels[0])
    assert all(s.out.source == ControlSource.FAILSAFE and s.out.throttle_us == 1500 for s in boot)
    reverse = [s.out.throttle_us for s in segment_samples(trace, labels[3])]
    assert reverse[0] == 1500 and spec.TIMING_BRAKE_TAP_US in reverse and reverse[-1] == 1300
    assert spec.TIMING_FAILSAFE_TIMEOUT_US < trace.failsafe_delay_us() <= spec.TIMING_FAILSAFE_TIMEOUT_US + 1000
    rc = segment_samples(trace, labels[6])
    assert rc[-1].out.source == ControlSource.RC and (rc[-1].out.throttle_us, rc[-1].out.steering_us) == (1600, 1200)
    replies = [r for _, r in trace.replies]
    assert replies[:3] == ["READY 1", "FAILSAFE", "ARMED"] and "ERR range" in replies and "ERR syntax" in replies
    assert any(s.out.brake_phase == BrakePhase.REVERSE_READY for s in trace.samples)


def test_main_prints_trace_and_writes_png(tmp_path, capsys):
    png = tmp_path / "trace.png"
    assert scripted_drive.main(["--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "ESC" in out and "Failsafe: neutral 251 ms" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_bad_plot_path_is_refused_before_the_run(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert run_command("roar drive-script", scripted_drive.main, ["--plot", str(blocker / "x.png")]) == 1
    err = capsys.readouterr()
    last = err.err.strip().splitlines()[-1]
    assert "--plot cannot write" in last and "is a file, not a folder" in last and err.out == ""
