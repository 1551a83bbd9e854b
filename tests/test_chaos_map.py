"""Two-parameter chaos maps (nld.analysis.chaos_map): a 2 x 2 clearance x friction grid with a few
revolutions per cell; a map killed after two cells and resumed on the local pool (2 workers) gives
the uninterrupted table; the same map on Dask; failing cells; verdicts against the exponent signs;
the heat map with its onset contour; the command line."""
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nld.analysis.chaos_map import SUMMARY_COLUMNS, chaos_map, chaos_map_plot, load_chaos_map
from nld.errors import InputError
from interrupt import run_and_kill

ROOT = Path(__file__).resolve().parent.parent
SCENE = "slider_crank_olyaei"              # Flores slider-crank with Ambrosio friction at B, 5000 rpm
PX, VX = "joints.B.clearance", [2e-4, 5e-4]
PY, VY = "joints.B.friction.mu", [0.0, 0.1]
KW = dict(transient_revs=2, revs=4, lyapunov_revs=4, rtol=1e-8)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted map, cell by cell in this process."""
    out = tmp_path_factory.mktemp("ref") / "map"
    return chaos_map(SCENE, PX, VX, PY, VY, workers=1, out=out, **KW), out


def test_table_files_provenance_and_verdicts(reference):
    df, out = reference
    assert list(df.columns) == SUMMARY_COLUMNS
    assert list(zip(df.x, df.y)) == [(x, y) for y in VY for x in VX]       # y outer, x inner
    assert list(df.ix) == [0, 1, 0, 1] and list(df.iy) == [0, 0, 1, 1]
    assert (df.status == "ok").all()
    # the verdict is the sign of the exponent where the uncertainty allows one
    for r in df.itertuples():
        assert r.per_revolution == pytest.approx(r.exponent * 2 * math.pi / 523.5987755982989)
        # (a span with no contact onset under the memory law is its own class, issue 25)
        want = ("permanent contact" if "permanent contact:" in r.message else
                "chaotic" if r.exponent - r.uncertainty > 0 else
                "regular" if r.exponent + r.uncertainty < 0 else "uncertain")
        assert r.verdict == want
    # friction-free 5000 rpm is chaotic at both clearances (lambda 3.5 - 4.6 per revolution over
    # 40 revolutions; a 4-revolution estimate scatters by about 2 per revolution: 2.2 - 3.3)
    assert (df[df.y == 0.0].verdict == "chaotic").all()
    assert (df[df.y == 0.0].per_revolution > 1).all()
    # 4 section points: no 0-1 test, and the message says why
    assert df.K.isna().all() and df.message.str.contains("K not computed").all()
    files = sorted(p.name for p in out.iterdir())
    assert files == [f"point-grid-{i:05d}.parquet" for i in range(4)] + ["provenance.json"]
    prov = json.loads((out / "provenance.json").read_text())
    assert prov["kind"] == "chaos_map" and prov["param"] == [[PX], [PY]]
    assert prov["values"] == [VX, VY] and prov["rtol"] == 1e-8 and prov["lyapunov_revs"] == 4
    for key in ("nld_version", "git_hash", "scene", "scene_parameters", "transient_revs", "revs",
                "lyapunov_rtol", "d0", "seed"):
        assert key in prov, key
    back = load_chaos_map(out)
    pd.testing.assert_frame_equal(back, df)
    assert back.attrs["param_x"] == [PX] and set(back.attrs["wall_s"]) == {0, 1, 2, 3}
    sec = load_chaos_map(out, sections=True)
    assert len(sec) == 16 and list(sec.rev.iloc[:4]) == [2, 3, 4, 5]
    assert (sec.observable == "B.ex").all() and sec.value.abs().max() <= 5e-4 * 1.05


def _verdict(lam, unc, status, lam_check=float("nan"), unc_check=float("nan")):
    from nld.analysis.verdict import verdict
    return verdict(lam, unc, lam_check=lam_check, unc_check=unc_check, failed=status != "ok")


def test_verdict_with_a_tolerance_check():
    assert _verdict(2.0, 0.5, "ok") == "chaotic" and _verdict(-2.0, 0.5, "ok") == "regular"
    assert _verdict(0.2, 0.5, "ok") == "uncertain" and _verdict(2.0, 0.5, "failed") == "failed"
    assert _verdict(2.0, 0.5, "ok", 2.5, 0.5) == "chaotic"          # agree: |2 - 2.5| <= 3 x 1
    assert _verdict(2.0, 0.5, "ok", 6.0, 0.5) == "not established"  # same sign, values disagree
    assert _verdict(2.0, 0.5, "ok", -1.0, 0.1) == "not established" # the sign flips
    assert _verdict(-2.0, 0.5, "ok", -2.2, 0.3) == "regular"


@pytest.mark.parametrize("mu", [0.1, 0.15])
def test_tolerance_check_on_the_former_integrator_exponent_cell(mu):
    """Slider-crank at 5000 rpm, c = 0.1 mm, mu = 0.1: before the contact memory of the
    perturbed trajectory was rescaled with its state (issue 13), Benettin's lambda here was 86
    per revolution at rtol 1e-10 and 10 at 1e-9 from the same state, and the check marked the
    cell 'uncertain' (with the integration chunked per revolution the same happened at
    mu = 0.15: 0.40 and 5.9). Now the two exponents agree within three times their combined
    uncertainty (docs/lyapunov.md, "Two trajectories and the discrete state"); a verdict may
    still differ where lambda is near zero."""
    kw = dict(transient_revs=50, revs=100, lyapunov_revs=20, rtol=1e-10, workers=1)
    checked = chaos_map(SCENE, PX, [1e-4], PY, [mu], rtol_check=1e-9, **kw)
    b = checked.iloc[0]
    assert abs(b.per_revolution - b.per_revolution_check) <= 3 * (
        b.uncertainty_per_revolution + b.uncertainty_per_revolution_check), b
    assert checked.attrs["provenance"]["rtol_check"] == 1e-9


def test_the_check_averages_over_check_span_times_the_span():
    """check_span = 2: the check's exponent is the tangent estimate over twice the span from the
    same state (the main exponent is unchanged); a check_span below 1 is refused."""
    from nld.analysis.lyapunov import lyapunov_tangent
    from nld.analysis.poincare import stroboscopic
    from nld.systems.core import SceneSystem
    df = chaos_map(SCENE, PX, [5e-4], PY, [0.1], workers=1, rtol_check=1e-9, check_span=2, **KW)
    row = df.iloc[0]
    ov = [f"{PX}=5e-4", f"{PY}=0.1"]
    sec = stroboscopic(SCENE, transient_revs=2, revs=4, observables=["B.ex"], rtol=1e-8, overrides=ov)
    s = SceneSystem(SCENE, ov)
    s.y0, s.z0 = sec.y_final.copy(), sec.z_final.copy()
    chk = lyapunov_tangent(s, transient=0.0, total=2 * 4 * s.period, rtol=1e-9)
    assert row.per_revolution_check == chk.per_revolution
    assert df.attrs["provenance"]["check_span"] == 2.0
    with pytest.raises(InputError, match="check_span = 0.5"):
        chaos_map(SCENE, PX, [5e-4], PY, [0.1], workers=1, rtol_check=1e-9, check_span=0.5, **KW)


def test_a_positive_exponent_over_a_short_section_is_not_chaotic(reference):
    """min_section_points = 5 with 4-point sections: the same exponents, no cell called chaotic
    (those that were are 'λ1 > 0, short', with a note saying why)."""
    ref, _ = reference
    df = chaos_map(SCENE, PX, VX, PY, VY, workers=1, min_section_points=5, **KW)
    np.testing.assert_array_equal(df["per_revolution"], ref["per_revolution"])
    assert (df["verdict"] != "chaotic").all()
    was = (ref["verdict"] == "chaotic").to_numpy()
    assert (df.loc[was, "verdict"] == "λ1 > 0, short").all()
    assert df.loc[was, "message"].str.contains("section of 4 points").all()
    assert (df.loc[~was, "verdict"].to_numpy() == ref.loc[~was, "verdict"].to_numpy()).all()
    with pytest.raises(InputError, match="min_section_points = -1"):
        chaos_map(SCENE, PX, VX, PY, VY, workers=1, min_section_points=-1, **KW)


def test_a_cell_is_the_section_and_exponent_of_its_scene(reference):
    """Cell (x = 5e-4, mu = 0.1) equals a direct stroboscopic section + the tangent estimator
    (the default) from its end."""
    from nld.analysis.lyapunov import lyapunov_tangent
    from nld.analysis.poincare import stroboscopic
    from nld.systems.core import SceneSystem
    df, out = reference
    ov = [f"{PX}=5e-4", f"{PY}=0.1"]
    sec = stroboscopic(SCENE, transient_revs=2, revs=4, observables=["B.ex"], rtol=1e-8,
                       overrides=ov)
    s = SceneSystem(SCENE, ov)
    s.y0, s.z0 = sec.y_final.copy(), sec.z_final.copy()
    lam = lyapunov_tangent(s, transient=0.0, total=4 * s.period, rtol=1e-8)
    row = df[(df.ix == 1) & (df.iy == 1)].iloc[0]
    assert row.exponent == lam.exponent and row.uncertainty == lam.uncertainty
    pts = load_chaos_map(out, sections=True)
    np.testing.assert_array_equal(pts[(pts.ix == 1) & (pts.iy == 1)].value, sec.table["B.ex"])


def test_the_exponent_integrator_reaches_the_cell_and_the_resume_check(reference, tmp_path):
    """estimator="benettin", lyapunov_method="dop853": the cell's exponent is the DOP853
    Benettin value from the end of the (DOPRI5) section, not DOPRI5's; provenance names both.
    The tangent estimator refuses another integrator and a d0. Resuming a map with another
    exponent integrator or estimator is refused; a map written before the options (no
    lyapunov_integrator / estimator in its provenance) resumes as DOPRI5 and Benettin, so it is
    refused by the tangent default."""
    import shutil

    from nld.analysis.bifurcation import PROVENANCE
    from nld.analysis.lyapunov import lyapunov_benettin
    from nld.analysis.poincare import stroboscopic
    from nld.systems.core import SceneSystem
    # the mu = 0 cell: slider_crank_olyaei without friction has slider_crank's structure, whose
    # DOP853 wrapper tests/test_integrators.py compiles too (one compilation per test run)
    df = chaos_map(SCENE, PX, [5e-4], PY, [0.0], workers=1, lyapunov_method="dop853",
                   estimator="benettin", **KW)
    ov = [f"{PX}=5e-4", f"{PY}=0.0"]
    sec = stroboscopic(SCENE, transient_revs=2, revs=4, observables=["B.ex"], rtol=1e-8,
                       overrides=ov)
    lam = {}
    for m in ("dop853", "dopri5"):
        s = SceneSystem(SCENE, ov, method=m)
        s.y0, s.z0 = sec.y_final.copy(), sec.z_final.copy()
        lam[m] = lyapunov_benettin(s, transient=0.0, total=4 * s.period, rtol=1e-8).exponent
    row = df.iloc[0]
    assert row.status == "ok" and row.exponent == lam["dop853"] != lam["dopri5"]
    prov = df.attrs["provenance"]
    assert prov["lyapunov_integrator"] == "dop853" and "dop853 (exponents)" in prov["integrator"]
    assert prov["estimator"] == "benettin" and "lyapunov_benettin" in prov["lyapunov_method"]
    with pytest.raises(InputError, match="lyapunov_method = .euler."):
        chaos_map(SCENE, PX, [5e-4], PY, [0.1], lyapunov_method="euler", **KW)
    with pytest.raises(InputError, match="lyapunov_method = 'dop853': the tangent estimator"):
        chaos_map(SCENE, PX, [5e-4], PY, [0.1], lyapunov_method="dop853", **KW)
    with pytest.raises(InputError, match="d0 = 1e-05: .* tangent estimator has none"):
        chaos_map(SCENE, PX, [5e-4], PY, [0.1], d0=1e-5, **KW)
    with pytest.raises(InputError, match="estimator = 'qr'"):
        chaos_map(SCENE, PX, [5e-4], PY, [0.1], estimator="qr", **KW)
    ref, out = reference
    old = tmp_path / "old"
    shutil.copytree(out, old)
    with pytest.raises(InputError, match="lyapunov_integrator differs"):
        chaos_map(SCENE, PX, VX, PY, VY, workers=1, out=old, resume=True,
                  lyapunov_method="rodas", estimator="benettin", **KW)
    with pytest.raises(InputError, match="differs"):
        chaos_map(SCENE, PX, VX, PY, VY, workers=1, out=old, resume=True,
                  estimator="benettin", **KW)
    p = json.loads((old / PROVENANCE).read_text())
    del p["lyapunov_integrator"]
    (old / PROVENANCE).write_text(json.dumps(p))
    again = chaos_map(SCENE, PX, VX, PY, VY, workers=1, out=old, resume=True, **KW)
    assert again.attrs["provenance"]["cells_run"] == 0
    pd.testing.assert_frame_equal(again, ref)
    p = json.loads((old / PROVENANCE).read_text())
    del p["estimator"]
    (old / PROVENANCE).write_text(json.dumps(p))
    with pytest.raises(InputError, match="estimator differs"):
        chaos_map(SCENE, PX, VX, PY, VY, workers=1, out=old, resume=True, **KW)


def test_killed_map_resumed_equals_uninterrupted(reference, tmp_path):
    """Killed after two cells, resumed on the local pool of 2 workers: the same table, and the
    finished cells are not run again."""
    ref, _ = reference
    out = tmp_path / "killed"
    code = ("from nld.analysis.chaos_map import chaos_map\n"
            f"chaos_map({SCENE!r}, {PX!r}, {VX!r}, {PY!r}, {VY!r}, workers=1, out={str(out)!r}, "
            f"**{KW!r})\n")
    done = run_and_kill(code, out)
    assert 2 <= len(done) < 4, "the map was not interrupted"
    assert not list(out.glob(".*.tmp"))
    stamps = {p.name: p.stat().st_mtime_ns for p in done}
    df = chaos_map(SCENE, PX, VX, PY, VY, workers=2, out=out, resume=True, **KW)
    pd.testing.assert_frame_equal(df, ref)
    pd.testing.assert_frame_equal(load_chaos_map(out), ref)
    assert all(p.stat().st_mtime_ns == stamps[p.name] for p in done)
    assert df.attrs["provenance"]["cells_run"] == 4 - len(done)
    # a different setting is refused on resume
    with pytest.raises(InputError, match="differs"):
        chaos_map(SCENE, PX, VX, PY, VY, workers=1, out=out, resume=True, seed=1, **KW)
    with pytest.raises(InputError, match="already holds"):
        chaos_map(SCENE, PX, VX, PY, VY, workers=1, out=out, **KW)


@pytest.mark.slow       # the default run checks dask on the bifurcation sweep (test_bifurcation.py)
def test_dask_gives_the_same_table(reference, tmp_path):
    distributed = pytest.importorskip("distributed")
    ref, _ = reference
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        dk = chaos_map(SCENE, PX, VX, PY, VY, dask=client, out=tmp_path / "dask", batch_size=1,
                       **KW)
    pd.testing.assert_frame_equal(dk, ref)
    pd.testing.assert_frame_equal(load_chaos_map(tmp_path / "dask"), ref)


def test_failing_cells_are_recorded_and_the_map_goes_on(tmp_path):
    """A negative clearance is refused by the scene check, and a run out of steps fails: both are
    'failed' cells with their message; the other cells run."""
    df = chaos_map(SCENE, PX, [-1e-4, 5e-4], PY, [0.1], workers=1, out=tmp_path / "f",
                   transient_revs=1, revs=2, lyapunov_revs=2, rtol=1e-8)
    assert list(df.status) == ["failed", "ok"] and list(df.verdict)[0] == "failed"
    assert "SceneError" in df.message[0] and "clearance" in df.message[0]
    assert df.exponent.isna()[0] and np.isfinite(df.exponent[1])
    assert len(list((tmp_path / "f").glob("point-grid-*.parquet"))) == 2
    df = chaos_map(SCENE, PX, [5e-4], PY, [0.1], workers=1, transient_revs=1, revs=2,
                   lyapunov_revs=2, rtol=1e-8, max_steps=100)
    assert df.status[0] == "failed" and "max_steps" in df.message[0]


def test_bad_input():
    with pytest.raises(InputError, match="not a value"):
        chaos_map(SCENE, "joints.B.nonsense", [1.0], PY, [0.0], workers=1)
    with pytest.raises(InputError, match="share"):
        chaos_map(SCENE, PX, [1e-4], PX, [2e-4], workers=1)
    with pytest.raises(InputError, match="resume"):
        chaos_map(SCENE, PX, [1e-4], PY, [0.0], resume=True)


def test_plot_draws_the_onset_contour(reference):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    df, _ = reference
    fig = chaos_map_plot(df)
    ax = fig.axes[0]
    labels = ax.get_legend_handles_labels()[1]
    lam = df.set_index(["ix", "iy"]).per_revolution
    # at c = 0.2 mm the onset lies between mu = 0 and 0.1 (4 revolutions per cell: 3.7 and -0.6)
    assert lam[(0, 1)] < 0 < lam[(0, 0)]
    assert "λ₁ = 0 (onset of chaos)" in labels
    cs = next(c for c in ax.collections if type(c).__name__ == "QuadContourSet")
    v = np.concatenate([p.vertices for p in cs.get_paths()])
    # the contour crosses the column c = 0.2 mm where lambda interpolates linearly to zero
    y0 = VY[0] + (VY[1] - VY[0]) * lam[(0, 0)] / (lam[(0, 0)] - lam[(0, 1)])
    on_col = v[np.isclose(v[:, 0], VX[0])]
    assert len(on_col) == 1 and on_col[0, 1] == pytest.approx(y0, rel=1e-9)
    assert ax.get_xlabel() == "joints.B.clearance (m)"
    plt.close(fig)
    # a map with a failed cell is drawn too (grey, hatched)
    bad = df.copy()
    bad.loc[0, ["status", "verdict"]] = "failed"
    bad.loc[0, ["exponent", "per_revolution"]] = np.nan
    fig = chaos_map_plot(bad, annotate=False)
    assert "failed / no value" in fig.axes[0].get_legend_handles_labels()[1]
    plt.close(fig)

    # a cell whose exponents at the two tolerances disagree is hatched though |lambda| > uncertainty
    def hatched(frame):
        f = chaos_map_plot(frame, annotate=False)
        n = sum(1 for p in f.axes[0].patches if p.get_hatch() == "//" and p.get_width() > 0)
        plt.close(f)
        return n
    clear = (df["per_revolution"].abs() > df["uncertainty_per_revolution"]) & (df["verdict"] != "uncertain")
    assert clear.any()
    k = clear.idxmax()
    unsure = df.copy()
    unsure.loc[k, "verdict"] = "uncertain"
    unsure["per_revolution_check"] = unsure["per_revolution"]
    assert hatched(unsure) == hatched(df) + 1


def test_cli_chaos_map(monkeypatch, capsys, tmp_path):
    from nld import cli
    out = tmp_path / "cli"
    args = ["chaos-map", SCENE, "--x", PX, "--x-values", "5e-4", "--y", PY, "--y-values", "0:0.1:2",
            "--transient-revs", "1", "--revs", "2", "--lyapunov-revs", "2", "--rtol", "1e-8",
            "--workers", "1", "--out", str(out)]
    assert cli.main(args + ["--plot", str(tmp_path / "m.png")]) == 0
    text = capsys.readouterr().out
    assert "[2/2] joints.B.clearance = 0.0005, joints.B.friction.mu = 0.1: lambda = " in text
    assert (tmp_path / "m.png").stat().st_size > 1000
    df = load_chaos_map(out)
    assert list(df.y) == [0.0, 0.1] and (df.status == "ok").all()
    assert cli.main(args + ["--resume"]) == 0 and "[" not in capsys.readouterr().out
    assert cli.main(args) == 2 and "already holds" in capsys.readouterr().err
    # a value the scene refuses is bad input before any cell runs (the API records a failed cell)
    assert cli.main(["chaos-map", SCENE, "--x", PX, "--x-values", "-1", "--y", PY, "--y-values", "0",
                     "--revs", "2", "--workers", "1", "--out", str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err
    assert "--x-values" in err and "-1" in err and "must be >= 0" in err
    assert not (tmp_path / "bad").exists()
