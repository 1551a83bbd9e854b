"""Study chaos_onset (studies/chaos_onset.py) in quick mode: files, pages, tables consistent with data.

Quick mode takes about 5-10 s on two cores with a warm kernel cache (3 x 3 slider-crank cells, 2 x 2
excavator cells, very short runs).
"""
from __future__ import annotations

import numpy as np
import pytest

from nld.output.io import load_table
from nld.output.report import Report
from study_harness import count_pages, run_quick


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    return run_quick("chaos_onset.py", tmp_path_factory)


def test_quick_writes_pdf_and_data(quick_run):
    study, out, pdf = quick_run
    assert pdf == out / "chaos_onset.pdf" and pdf.is_file()
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF") and b"quick" in data
    # title page(s) + intro, findings, summary table, boundary table, 3 maps, discussion, the
    # curves' page and their figure (no curve in quick mode: the page says why)
    title_pages = Report(out / "x.pdf", study.TITLE).title_page_count()
    assert count_pages(pdf) == title_pages + 10
    for f in ("chaos_onset.parquet", "chaos_onset_summary.csv", "chaos_onset_boundary.csv",
              "chaos_onset_curves.csv"):
        assert (out / f).is_file()
    curves, prov = load_table(out / "chaos_onset_curves.csv")
    assert len(curves) == 0 and prov["curves"]["skipped"] == study.CURVES_SKIPPED
    assert "clearance_m" in curves.columns


def test_explain_counts_the_map_boundaries_a_curve_crosses(quick_run):
    # a synthetic map row and curve: the curve crosses mu = 0.1 between the cells 0.2 and 0.3 mm
    # (a regular/chaotic sign change: explained) and mu = 0.2 between two regular cells (a
    # disagreement); the sign change at mu = 0.2 between 0.3 and 0.5 mm is crossed by no curve
    import pandas as pd
    from types import SimpleNamespace
    study, _, _ = quick_run
    rows = []
    for y, verdicts in ((0.1, ["regular", "regular", "chaotic", "chaotic"]),
                        (0.2, ["regular", "regular", "regular", "chaotic"])):
        for x, v in zip([0.1e-3, 0.2e-3, 0.3e-3, 0.5e-3], verdicts):
            rows.append({"x": x, "y": y, "verdict": v})
    curve = SimpleNamespace(kind="period_doubling", values1=[0.25e-3, 0.26e-3, 0.27e-3],
                            values2=[0.05, 0.1, 0.25])
    ex = study.explain(pd.DataFrame(rows), {"curves": [curve]})
    got = {(r.mu, r.c_left_mm): (r.map_boundary, r.curves, r.agree) for r in ex.itertuples()}
    assert got == {(0.1, 0.2): (True, "period_doubling", True),
                   (0.2, 0.2): (False, "period_doubling", False),
                   (0.2, 0.3): (True, "-", False)}


def test_summary_matches_stored_map(quick_run):
    study, out, _ = quick_run
    cells, prov = load_table(out / "chaos_onset.parquet")
    summary, _ = load_table(out / "chaos_onset_summary.csv")
    assert prov["mode"] == "quick"
    assert set(cells["case"]) == set(study.MAPS) == set(summary["map"])
    for _, row in summary.iterrows():
        st = study.QUICK[row["map"]]
        m = cells[cells["case"] == row["map"]]
        assert len(m) == row["cells"] == len(st["values_x"]) * len(st["values_y"])
        assert sorted(m["x"].unique()) == pytest.approx(sorted(st["values_x"]))
        ok = m[m["status"] == "ok"]
        assert row["max_lambda_per_rev"] == pytest.approx(ok["per_revolution"].max(), rel=1e-12)
        assert row["min_lambda_per_rev"] == pytest.approx(ok["per_revolution"].min(), rel=1e-12)
        for v in ("chaotic", "regular", "failed"):
            assert row[v] == (m["verdict"] == v).sum()
        assert row["uncertain"] == m["verdict"].isin(["uncertain", "λ1 > 0, short"]).sum()
        assert row["not_established"] == (m["verdict"] == "not established").sum()
        assert row["permanent_contact"] == (m["verdict"] == "permanent contact").sum()
        assert row[["chaotic", "regular", "failed", "uncertain", "not_established",
                    "permanent_contact"]].sum() == len(m)
        # verdicts follow the exponent and its uncertainty
        ch = ok[ok["verdict"] == "chaotic"]
        assert (ch["per_revolution"] - ch["uncertainty_per_revolution"] > 0).all()
        assert row["tolerance_dependent"] == m["message"].str.contains("depends on the tolerance").sum()
        if st.get("rtol_check"):        # a chaotic cell passed the check at the second tolerance too
            assert ch["per_revolution_check"].notna().all()
            assert (ch["per_revolution_check"] - ch["uncertainty_per_revolution_check"] > 0).all()
        else:
            assert m["per_revolution_check"].isna().all()
        assert np.allclose(ok["per_revolution"], ok["exponent"] * 2 * np.pi /
                           prov["maps"][row["map"]]["chaos_map_provenance"]["scene_parameters"]["driver"]["speed"])


def test_boundary_table_brackets_sign_changes(quick_run):
    study, out, _ = quick_run
    cells, _ = load_table(out / "chaos_onset.parquet")
    bnd, _ = load_table(out / "chaos_onset_boundary.csv")
    for _, row in bnd.iterrows():
        g = cells[(cells["case"] == row["map"]) & np.isclose(cells["y"], row["mu"])].sort_values("x")
        lam = g["per_revolution"].to_numpy()
        changes = int((np.sign(lam[1:]) != np.sign(lam[:-1])).sum())
        onset = str(row["onset clearances [mm]"])
        assert (onset == "-") == (changes == 0)
        if changes:
            xs = [float(v) for v in onset.split(",")]
            assert len(xs) == changes
            assert all(g["x"].min() * 1e3 <= x <= g["x"].max() * 1e3 for x in xs)


def test_rerun_reads_finished_cells_back(quick_run):
    # the cells are kept under <out>/.work/; a second run (e.g. after an interruption) reads them
    # back instead of recomputing: same table, the same per-cell wall times
    study, out, _ = quick_run
    before, _ = load_table(out / "chaos_onset.parquet")
    work = [study.work_dir(out, name, "quick") for name in study.MAPS]
    assert all(len(list(w.glob("point-*.parquet"))) > 0 for w in work)
    gone = sorted(work[0].glob("point-*.parquet"))[0]
    gone.unlink()                       # as if the run had been interrupted before that cell
    study.main(quick=True, out_dir=out)
    after, _ = load_table(out / "chaos_onset.parquet")
    assert len(after) == len(before)
    cols = ["case", "ix", "iy", "per_revolution", "verdict", "K"]
    a = before[cols].sort_values(["case", "iy", "ix"]).reset_index(drop=True)
    b = after[cols].sort_values(["case", "iy", "ix"]).reset_index(drop=True)
    assert a.equals(b)
    recomputed = (before.sort_values(["case", "iy", "ix"])["wall_s"].to_numpy()
                  != after.sort_values(["case", "iy", "ix"])["wall_s"].to_numpy())
    assert recomputed.sum() == 1        # only the removed cell ran again


def test_full_excavator_grid_includes_mu_0_1():
    """Coulomb friction as hybrid stick/slip modes (issue 14) puts μ = 0.1 back in the excavator's
    full grid, at a tolerance where the small clearances do not chatter (rtol <= 1e-7)."""
    from study_harness import load_study
    ex = load_study("chaos_onset.py").FULL["excavator"]
    assert max(ex["values_y"]) == pytest.approx(0.1)
    assert ex["rtol"] <= 1e-7 and ex["rtol_check"] < ex["rtol"]
