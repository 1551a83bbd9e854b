"""Writing a benchmark's markdown result (benchmarks/results/*.md), shared by the scripts here."""
from __future__ import annotations

from pathlib import Path


def write_table(out, head: list[str], rows: list[str]) -> str:
    """Write the header lines and the table rows to ``out`` (folders created); returns the text."""
    text = "\n".join(head + rows) + "\n"
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(text)
    print(f"wrote {out}")
    return text
