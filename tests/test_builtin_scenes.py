"""Every built-in scene: its ideal twin closes the loop and balances power; it runs three revolutions."""
import numpy as np
import pytest

from nld.model.ideal import ideal_solution, loop_closure_error
from nld.model.scene import builtin_scenes, load_scene
from nld.run.simulate import crank_period

SCENES = sorted(builtin_scenes())


def spectral_derivative(f, period):
    """d f/dt of a smooth periodic sample over one period (uniform, endpoint excluded)."""
    n = len(f)
    k = np.fft.rfftfreq(n, d=period / n) * 2 * np.pi
    return np.fft.irfft(1j * k * np.fft.rfft(f), n)


@pytest.mark.parametrize("name", SCENES)
def test_ideal_twin_closes_loop_and_balances_power(name):
    sc = load_scene(name)
    T = crank_period(sc)
    t = np.linspace(0.0, T, 512, endpoint=False)
    df = ideal_solution(sc, t)
    assert loop_closure_error(sc, df) < 1e-10
    dEdt = spectral_derivative(df["energy.total"].to_numpy(), T)
    P = (df["power.driver"] + df["power.loads"]).to_numpy()
    ref = np.abs(df["power.driver"]).max()
    assert np.abs(dEdt - P).max() < 1e-6 * ref, np.abs(dEdt - P).max() / ref


def test_slider_crank_runs_three_revolutions():
    from nld.run.simulate import simulate
    r = simulate("slider_crank", revs=3)
    assert r.success, r.message
    assert np.isfinite(r.table.to_numpy()).all()
    assert (r.events.direction == 1).sum() > 10
