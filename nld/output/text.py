"""Text broken into lines at sensible points, for table cells, the title page and figure labels
(nld.output.report, nld.output.plots)."""
from __future__ import annotations

import re

_BREAK = None


def split_value(text: str, width: int) -> list[str]:
    """``text`` in lines of at most ``width`` characters where it can be, broken only at sensible
    points: after a space, ``_``, ``/``, ``,``, ``;`` or a ``.`` between lower-case letters (module
    paths, file names), never inside a word or a number; a token longer than ``width`` stays whole.
    Line breaks already in the text are kept."""
    global _BREAK
    if _BREAK is None:
        _BREAK = re.compile(r"(?<=[ _/,;])|(?<=[a-z]\.)(?=[a-z_])")
    out: list[str] = []
    for line in str(text).split("\n"):
        tokens = [t for t in _BREAK.split(line) if t]
        cur = ""
        for t in tokens:
            if cur and len((cur + t).rstrip()) > width:
                out.append(cur.rstrip())
                cur = t.lstrip() if t.strip() else ""
            else:
                cur += t
        out.append(cur.rstrip())
    return out
