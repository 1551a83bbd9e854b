"""Shared helpers of the study tests (tests/test_study_*.py): load a study script, run its quick
mode into a temporary directory, count the pages of a PDF."""
from __future__ import annotations

import importlib.util
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def load_study(filename: str):
    """Import studies/<filename> as a module (the studies are scripts, not a package)."""
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


def run_quick(filename: str, tmp_path_factory, **kwargs):
    """(study module, output directory, PDF path) of the study's quick mode."""
    study = load_study(filename)
    out = tmp_path_factory.mktemp(Path(filename).stem)
    pdf = study.main(quick=True, out_dir=out, **kwargs)
    return study, out, pdf
