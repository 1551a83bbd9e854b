"""Bad sizes and arguments of the orbit search refused before any integration, naming the
argument or option and what is allowed (issue 37 classes 1, 2, 5)."""
import numpy as np
import pytest

import nld.analysis.orbits as O
from nld.analysis.orbits import find_orbits, periodic_orbit
from nld.cli import main
from nld.errors import InputError
from nld.systems import henon
from nld.systems.derived import NumbaMap, _FlowMap


@pytest.fixture
def no_integration(monkeypatch):
    """Any integration of a derived map fails the test (and never hangs it)."""
    def refuse(*a, **k):
        raise AssertionError("integrated before the arguments were checked")
    monkeypatch.setattr(_FlowMap, "_plain", refuse)
    monkeypatch.setattr(_FlowMap, "_tangent", refuse)
    monkeypatch.setattr(NumbaMap, "step", refuse)


def _scene():
    from nld.systems import SceneSystem
    return SceneSystem("slider_crank")


@pytest.mark.parametrize("kwargs, words", [
    ({"n_points": 0}, "n_points = 0: must be a whole number >= 2"),
    ({"n_points": -5}, "n_points"),
    ({"n_points": 2.5}, "n_points"),
    ({"seeds_per_period": -1}, "seeds_per_period = -1: must be a whole number >= 0"),
    ({"transient": -1}, "transient"),
    ({"max_period": 200}, "max_period = 200: .* at most 119"),
    ({"max_period": 10, "n_points": 10}, "max_period = 10: .* at most 9"),
    ({"max_period": 900, "n_points": 2000}, "max_period = 900: too long.* at most 800"),
    ({"grid": 5}, "grid = 5: .*DiscreteMap"),
    ({"stabilising": 3}, "stabilising = 3: .*DiscreteMap"),
    ({"tol": -1.0}, "tol"),
    ({"min_period": 3, "max_period": 2}, "min_period"),
])
def test_find_orbits_arguments_checked_before_any_integration(kwargs, words, no_integration):
    kwargs = dict(kwargs)
    P = kwargs.pop("max_period", 2)
    with pytest.raises(InputError, match=words):
        find_orbits(_scene(), P, **kwargs)


def test_find_orbits_map_arguments(no_integration):
    with pytest.raises(InputError, match="max_period = 2000: .* at most 1999"):
        find_orbits(henon(), 2000)
    with pytest.raises(InputError, match="max_period = 50: .* at most 19"):
        find_orbits(henon(), 50, n_points=20)
    with pytest.raises(InputError, match="seeds_per_period"):
        find_orbits(henon(), 2, seeds_per_period=-1)
    with pytest.raises(InputError, match="stabilising"):
        find_orbits(henon(), 2, stabilising=-2)


def test_period_too_long_for_shooting_is_refused_with_the_largest_that_fits(no_integration):
    N = 5                                   # slider_crank: 4 states and a contact memory
    most = getattr(O, "MAX_SHOOTING_UNKNOWNS", 4000) // N
    with pytest.raises(InputError, match=f"period = 1000000000: too long.* at most {most}"):
        periodic_orbit(_scene(), 10 ** 9)
    with pytest.raises(InputError, match="period = 1000000: too long.* at most 2000"):
        periodic_orbit(henon(), 10 ** 6, np.zeros(2))


@pytest.mark.parametrize("argv, words", [
    (["--period", "1000000000"], "--period = 1000000000: too long"),
    (["--max-period", "1000"], "--max-period = 1000: the section it seeds from has 120 points"),
])
def test_cli_sizes_refused_before_any_integration(argv, words, no_integration, capsys):
    assert main(["orbits", "slider_crank"] + argv + ["--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and "at most" in err and len(err.splitlines()) == 1
