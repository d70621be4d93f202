"""Circuit-like tracks from a seed (`circuit:SEED`): the shape of the real 1:10 circuits, measured
the way a person would describe one (bends under 10 m, their radii, the longest straight and the
bend it ends in, chicanes), the same on every machine, refused in one line when impossible."""

import pytest

pytest.importorskip("shapely", reason="pip install 'roar-platform[tracks]' (make setup installs it)")

from roar.tracks import TrackError, get  # noqa: E402
from roar.tracks.circuit_track import SHAPE, shape  # noqa: E402
from roar.tracks.names import split_names  # noqa: E402
from roar.tracks.random_track import rounded_polygon  # noqa: E402
from roar.tracks.track import Track  # noqa: E402


def test_shape_measures_a_known_track():
    """Two 180-degree bends of 1.5 m joined by 4 m straights: 2 bends, median and tightest 1.5 m,
    the longest straight 4 m (less the 0.25 m chord the radius is measured over, at either end)
    into a 1.5 m bend, no chicane; a jog on one straight is a chicane."""
    oval = get("oval")
    figures = shape(oval)
    assert (figures.bends, figures.chicanes) == (2, 0)
    assert figures.median_radius_m == pytest.approx(1.5, abs=0.1) and figures.tightest_m == pytest.approx(1.5, abs=0.1)
    assert figures.straight_m == pytest.approx(4.0 - 2 * 0.25, abs=0.15) and figures.into_m == pytest.approx(1.5, abs=0.1)
    jogged = Track("jog", rounded_polygon([(0, 0), (20, 0), (24, 2), (28, 2), (32, 0), (52, 0), (52, 30), (0, 30)],
                                          [5, 3, 3, 3, 3, 5, 5, 5]), 2.2)
    assert shape(jogged).chicanes == 1 and shape(jogged).bends == 8


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5, 6])
def test_a_circuit_has_a_real_circuits_shape_and_never_meets_itself(seed):
    track = get(f"circuit:{seed}")
    figures = shape(track)
    assert 260 <= track.length_m <= 490 and track.width_m == 2.2
    assert figures.problem() is None, figures
    assert SHAPE.bends[0] <= figures.bends <= SHAPE.bends[1] and SHAPE.tightest_m[0] <= figures.tightest_m <= 2.0
    assert figures.chicanes >= 1  # one or two long sides carry one
    assert len(track.walls) == 2 and track.uniform_width  # one infield, no part narrowed by another
    radii = track.bend_radii()
    assert radii[:20].min() > 50  # the start is on a straight: the main one, as on a grid


def test_a_circuit_seed_names_one_track_and_its_parameters_shape_it():
    a, b = get("circuit:3"), get("circuit:3")
    assert a.fingerprint == b.fingerprint and a.name == "circuit:3"
    assert get("circuit:4").fingerprint != a.fingerprint
    short = get("circuit:3,length=300-310,width=2")
    assert 300 <= short.length_m <= 310 and short.width_m == 2.0 and short.name == "circuit:3,length=300-310,width=2"
    assert split_names("circuit:1-3,width=2") == ["circuit:1,width=2", "circuit:2,width=2", "circuit:3,width=2"]


@pytest.mark.parametrize("name, fragment", [
    ("circuit:", "seed must be a whole number"), ("circuit:1,length=100-150", "length must be MIN-MAX within 200-500"),
    ("circuit:1,length=300-600", "length must be"), ("circuit:1,width=4", "width must be"),
    ("circuit:1,radius=1", "unknown parameter"), ("circuit:1,width=x", "width needs a number"),
])
def test_bad_circuit_names_fail_in_one_line(name, fragment):
    with pytest.raises(TrackError) as e:
        get(name)
    assert fragment in str(e.value) and "\n" not in str(e.value)


def test_random_tracks_may_be_as_long_as_a_circuit():
    track = get("random:2,length=450-490,width=2.2,radius=1")
    assert 450 <= track.length_m <= 490
