"""PDF report builder (nld.output.report): page count, metadata, reproducible bytes, study data on disk."""
from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

from nld.output.io import load_table
from nld.output.report import Report, save_study_data


def count_pages(path) -> int:
    try:
        from pypdf import PdfReader
    except ImportError:
        data = path.read_bytes()
        return len(re.findall(rb"/Type\s*/Page(?![a-zA-Z])", data))
    return len(PdfReader(str(path)).pages)


def write_report(path, *, scene="slider_crank", table_rows=3):
    prov = {"integrator": "dopri5", "rtol": 1e-8, "scene": "slider_crank"}
    with Report(path, "Test report", scene=scene, provenance=prov,
                settings={"revolutions": 2, "samples per revolution": 360},
                subtitle="QUICK MODE", highlight_subtitle=True, keywords=["test"]) as rep:
        rep.text_page("Notes", ["A first paragraph. " * 20, "- a bullet", "- another bullet",
                                "A closing paragraph."])
        with rep.style():
            fig, ax = rep.subplots(1, 1, title="A curve")
            t = np.linspace(0.0, 1.0, 50)
            ax.plot(t, np.sin(2 * np.pi * t), label="sin")
            ax.set_xlabel("time t [s]")
            ax.set_ylabel("angle [rad]")
            ax.legend()
        rep.figure(fig, caption="A sine.")
        rows = [{"case": f"c{i}", "omega": 1.5 * i, "F": np.nan if i == 0 else 1e4 * i}
                for i in range(table_rows)]
        rep.table("Peaks", pd.DataFrame(rows), col_units={"omega": "rad/s", "F": "N"}, notes="Notes.")
    return path


def test_three_content_pages_plus_title_page(tmp_path):
    path = write_report(tmp_path / "sub" / "r.pdf")
    assert path.is_file()
    data = path.read_bytes()
    assert data.startswith(b"%PDF")
    # slider_crank's parameters fit on the title page: 1 title page + text + figure + table
    assert count_pages(path) == 4
    assert b"nld" in data
    assert not list(path.parent.glob(".*.tmp"))


def test_metadata_has_author_and_git_hash(tmp_path):
    from nld.output.provenance import git_hash
    rep = Report(tmp_path / "m.pdf", "Meta", scene="slider_crank")
    md = rep.metadata()
    assert md["Author"] == "nld" and md["Title"] == "Meta"
    assert git_hash() in md["Keywords"] and "slider_crank" in md["Subject"]


def test_source_date_epoch_gives_identical_bytes(tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    a = write_report(tmp_path / "a.pdf").read_bytes()
    b = write_report(tmp_path / "b.pdf").read_bytes()
    assert a == b
    assert b"D:20231114" in a            # CreationDate from SOURCE_DATE_EPOCH (2023-11-14 22:13 UTC)


def test_long_table_continues_over_pages(tmp_path):
    path = write_report(tmp_path / "long.pdf", scene=None, table_rows=30)
    assert count_pages(path) == 5        # title, text, figure, table over 2 pages (24 rows per page)


def test_failed_block_leaves_no_pdf(tmp_path):
    path = tmp_path / "fail.pdf"
    with pytest.raises(RuntimeError):
        with Report(path, "Fails") as rep:
            rep.text_page("x", "y")
            raise RuntimeError("boom")
    assert not path.exists()


def test_save_study_data_stacks_cases(tmp_path):
    a = pd.DataFrame({"t": [0.0, 1.0], "x": [1.0, 2.0]})
    b = pd.DataFrame({"t": [0.0], "y": [3.0]})
    p = save_study_data({"a": a, "b": b}, tmp_path / "s.pdf", {"study": "test"})
    assert p.suffix == ".parquet" and p.is_file()
    df, prov = load_table(p)
    assert list(df["case"]) == ["a", "a", "b"]
    assert np.isnan(df["y"].iloc[0]) and df["y"].iloc[2] == 3.0
    assert prov == {"study": "test"}


def test_footer_title_never_overlaps_the_page_number(tmp_path):
    # a long study title (chaos_onset's) used to run into 'page i of N' in the footer
    title = ("Onset of chaos over clearance x friction: slider-crank and excavator "
             "(largest Lyapunov exponent)")
    rep = Report(tmp_path / "f.pdf", title)
    with rep.style():
        fig, _ = rep.subplots(1, 1)
    n_before = len(fig.texts)
    rep._footer(fig, 5, 9)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    renderer = FigureCanvasAgg(fig).get_renderer()
    left, centre, right = (t.get_window_extent(renderer) for t in fig.texts[n_before:])
    assert left.x1 < centre.x0 and centre.x1 < right.x0
    assert fig.texts[n_before].get_text().endswith("…")
    import matplotlib.pyplot as plt
    plt.close(fig)


def test_text_page_stays_inside_the_right_margin(tmp_path):
    """Running text wraps so that the longest line ends inside the page margin (at 145 characters
    per line, long bullets ran past the right edge of an A4 landscape page)."""
    from pathlib import Path
    from nld.output import report
    rep = report.Report(tmp_path / "t.pdf", "t")
    words = Path(__file__).resolve().parent.parent.joinpath("docs", "studies.md").read_text()
    paragraphs = [p.replace("\n", " ") for p in words.split("\n\n")[:40]]
    rep.text_page("margins", paragraphs)
    fig = rep._pages[-1]
    fig.canvas.draw()
    right = max(t.get_window_extent().x1 for t in fig.texts) / fig.bbox.width
    assert right <= 1.0 - report._MARGIN


def test_git_hash_from_the_environment_takes_precedence(monkeypatch):
    """A batch copy names its commit in NLD_GIT_HASH; its own .git (possibly stale) is not asked."""
    from nld.output import provenance
    provenance.git_hash.cache_clear()
    try:
        monkeypatch.setenv("NLD_GIT_HASH", "abc1234")
        assert provenance.git_hash() == "abc1234 (NLD_GIT_HASH)"
        provenance.git_hash.cache_clear()
        monkeypatch.delenv("NLD_GIT_HASH")
        h = provenance.git_hash()
        assert "NLD_GIT_HASH" not in h
    finally:
        provenance.git_hash.cache_clear()
