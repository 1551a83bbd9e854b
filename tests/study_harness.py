"""Shared helpers of the study tests (tests/test_study_*.py): load a study script, run its quick
mode into a temporary directory, count the pages of a PDF, record what a study puts into its
report."""
from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def load_study(filename):
    """Import studies/<filename> (or the file at an absolute path) as a module (the studies are
    scripts, not a package; the module is not put into sys.modules)."""
    path = ROOT / "studies" / filename
    spec = importlib.util.spec_from_file_location(f"{path.stem}_study_under_test", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def count_pages(path) -> int:
    """Pages of a PDF (pypdf if installed, else the page objects in the file)."""
    try:
        from pypdf import PdfReader
    except ImportError:
        return len(re.findall(rb"/Type\s*/Page(?![a-zA-Z])", Path(path).read_bytes()))
    return len(PdfReader(str(path)).pages)


def run_quick(filename: str, tmp_path_factory, mode: str = "quick", **kwargs):
    """(study module, output directory, PDF path) of the study's quick mode (``mode="smoke"``: its
    smoke mode). The module gets ``MODE`` (the mode's name) and ``MODE_SETTINGS`` (its dict)."""
    study = load_study(filename)
    out = tmp_path_factory.mktemp(f"{Path(filename).stem}_{mode}")
    if mode == "smoke":
        kwargs["smoke"] = True
    pdf = study.main(quick=True, out_dir=out, **kwargs)
    study.MODE, study.MODE_SETTINGS = mode, getattr(study, mode.upper())
    return study, out, pdf


class ReportRecorder:
    """Records what the study puts into its Report (captions, the axes of each figure, table notes,
    the title page's rows) while the quick run writes it."""

    def __init__(self):
        self.figures, self.tables, self.info = [], [], []

    def __enter__(self):
        rec = self
        from nld.output.report import Report
        self._orig = (Report.figure, Report.table, Report._info_lines)

        def figure(rep, fig, caption=None):
            sup = fig.get_suptitle()
            axes = [dict(xlim=ax.get_xlim(), ylim=ax.get_ylim(), xlabel=ax.get_xlabel(),
                         ylabel=ax.get_ylabel(), title=ax.get_title(),
                         legend=[t.get_text() for t in ax.get_legend().get_texts()] if ax.get_legend() else [])
                    for ax in fig.axes]
            rec.figures.append(dict(title=sup, caption=caption or "", axes=axes))
            return rec._orig[0](rep, fig, caption)

        def table(rep, title, data, col_units=None, **kw):
            rec.tables.append(dict(title=title, notes=" ".join(kw.get("notes") or []),
                                   columns=list(getattr(data, "columns", []))))
            return rec._orig[1](rep, title, data, col_units, **kw)

        def info(rep, epoch):
            rows = rec._orig[2](rep, epoch)
            rec.info = rows
            return rows

        Report.figure, Report.table, Report._info_lines = figure, table, info
        return self

    def __exit__(self, *exc):
        from nld.output.report import Report
        Report.figure, Report.table, Report._info_lines = self._orig
        return False

    def figure(self, words: str) -> dict:
        hits = [f for f in self.figures if words in f["title"]]
        assert len(hits) == 1, (words, [f["title"] for f in self.figures])
        return hits[0]

    def wall_time(self) -> float:
        row = dict(self.info).get("Wall time", "")
        return float(row.split(" s")[0]) if row[:1].isdigit() else float("nan")


def run_quick_recorded(filename: str, tmp_path_factory, mode: str = "quick"):
    """(study module, output directory, PDF path, ReportRecorder) of the study's quick (or smoke)
    mode."""
    with ReportRecorder() as rec:
        study, out, pdf = run_quick(filename, tmp_path_factory, mode)
    return study, out, pdf, rec


# the modes a study's test file runs: smoke in the default run, the quick mode as its -m slow variant
MODES = ["smoke", pytest.param("quick", marks=pytest.mark.slow)]
