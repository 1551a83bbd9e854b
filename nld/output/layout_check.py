"""Layout check of PDF reports: finds what a reader cannot read.

    from nld.output.layout_check import check_pdf
    for d in check_pdf("reports/x.pdf"):
        print(d)                     # "p3 text-overlap: 'c=0.05 mm' over 'not established'"

Reads the page content with pymupdf (``pip install pymupdf``; a test dependency, not needed to make
reports) as a reviewer sees it and reports, page by page:

- ``off-page``: text that runs off the page or into the footer band (the bottom
  :data:`FOOTER_PT` points, which only the footer may use);
- ``text-overlap``: two pieces of text that overlap each other (tick labels colliding, a panel
  title over the axis label above it, a table over the footer);
- ``cell-overflow``: text that crosses the border of the table cell it sits in;
- ``under-legend``: text or data (markers, curves) drawn underneath a legend's box, and text
  drawn later that crosses a legend's box;
- ``panel-overlap``: text that crosses the edge of a plot panel (axes) it partly lies in, e.g. an
  axis label of one panel running into the panel below.

Text boxes are the glyphs' ink extent along the baseline (from 0.72 of the font size above it to
0.2 below, not the font's whole line height), so the lines of a paragraph do not count as
overlapping. The geometry is that of matplotlib's PDF output: table cells are stroked and filled
rectangles, legends stroked and filled rounded boxes, panels white filled rectangles. Tolerances
are in points (1/72 inch).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

__all__ = ["Defect", "check_pdf", "check_page", "pdf_git_hash", "FOOTER_PT"]

FOOTER_PT = 24.0        # the bottom band of the page kept for the footer (report._FOOTER_H of A4)
TOL = 1.0               # overlaps smaller than this (points) are not counted


@dataclass(frozen=True)
class Defect:
    page: int            # 1-based
    kind: str            # off-page, text-overlap, cell-overflow, under-legend, panel-overlap
    text: str

    def __str__(self) -> str:
        return f"p{self.page} {self.kind}: {self.text}"


@dataclass
class _Span:
    x0: float
    y0: float
    x1: float
    y1: float
    text: str
    seqno: int
    footer: bool = False

    @property
    def cx(self):
        return 0.5 * (self.x0 + self.x1)

    @property
    def cy(self):
        return 0.5 * (self.y0 + self.y1)


def _short(s: str, n: int = 40) -> str:
    s = " ".join(s.split())
    return repr(s if len(s) <= n else s[:n - 1] + "…")


def _spans(page) -> list[_Span]:
    """The page's text pieces as drawn (pymupdf's text trace: not merged into lines, so that two
    colliding labels stay two), each box the non-blank glyphs' ink extent."""
    out = []
    for s in page.get_texttrace():
        dx, dy = s["dir"]
        size = float(s["size"])
        chars = [c for c in s["chars"] if chr(c[0]).strip()]
        if not chars or s.get("opacity", 1.0) == 0:
            continue
        text = "".join(chr(c[0]) for c in s["chars"]).strip()
        xs0 = min(c[3][0] for c in chars)
        xs1 = max(c[3][2] for c in chars)
        ys0 = min(c[3][1] for c in chars)
        ys1 = max(c[3][3] for c in chars)
        if abs(dy) < 1e-3:                       # horizontal: the ink band around the baseline
            base = chars[0][2][1]
            sign = 1.0 if dx > 0 else -1.0
            y0, y1 = sorted((base - sign * 0.72 * size, base + sign * 0.2 * size))
            out.append(_Span(xs0, max(ys0, y0), xs1, min(ys1, y1), text, s["seqno"]))
        elif abs(dx) < 1e-3:                     # vertical (a y label)
            base = chars[0][2][0]
            sign = 1.0 if dy < 0 else -1.0       # up the page: glyphs stand to the left of it
            x0, x1 = sorted((base - sign * 0.72 * size, base + sign * 0.2 * size))
            out.append(_Span(max(xs0, x0), ys0, min(xs1, x1), ys1, text, s["seqno"]))
        else:
            out.append(_Span(xs0, ys0, xs1, ys1, text, s["seqno"]))
    return out


def _overlap(a, b) -> tuple[float, float]:
    return (min(a.x1, b.x1) - max(a.x0, b.x0), min(a.y1, b.y1) - max(a.y0, b.y0))


def _inside(s, r, tol=TOL) -> bool:
    return s.x0 >= r.x0 - tol and s.x1 <= r.x1 + tol and s.y0 >= r.y0 - tol and s.y1 <= r.y1 + tol


def _contains_point(r, x, y) -> bool:
    return r.x0 <= x <= r.x1 and r.y0 <= y <= r.y1


def _points(d):
    """The points of a drawing's path items (raw tuples of ``page.get_cdrawings()``: a line or
    curve item holds (x, y) pairs, a rectangle item (x0, y0, x1, y1), a quad four pairs)."""
    for it in d["items"]:
        for p in it[1:]:
            if not isinstance(p, tuple):
                continue
            if len(p) == 2:
                yield p
            elif len(p) == 4 and all(isinstance(q, tuple) for q in p):   # a quad
                yield from p
            elif len(p) == 4:                                            # a rect
                yield (p[0], p[1])
                yield (p[2], p[3])


def _drawings(page) -> list[dict]:
    """The page's vector drawings, as ``page.get_cdrawings()`` gives them (plain tuples: four
    times faster than ``get_drawings()``, whose Point objects cost most of a check), with each
    drawing's ``rect`` made a pymupdf Rect."""
    import pymupdf
    out = page.get_cdrawings()
    for d in out:
        d["rect"] = pymupdf.Rect(d["rect"])
    return out


def check_page(page, number: int = 1) -> list[Defect]:
    """The layout defects of one pymupdf page (``number``: its 1-based page number, for the
    messages)."""
    W, H = page.rect.width, page.rect.height
    spans = _spans(page)
    drawings = _drawings(page)
    out: list[Defect] = []
    # the footer (report._footer): the line of "page i of N" on the bottom band, drawn last; the
    # band is checked only on pages that have one
    import re
    pages = [s for s in spans if s.y0 > H - FOOTER_PT and re.fullmatch(r"page \d+ of \d+", s.text)]
    has_footer = bool(pages)
    if pages:
        p = max(pages, key=lambda s: s.seqno)
        first = min(s.seqno for s in spans if abs(s.y1 - p.y1) < 1.0 and s.y0 > H - FOOTER_PT - 8)
        for s in spans:
            s.footer = abs(s.y1 - p.y1) < 1.0 and s.seqno >= first - 1e-9 and s.y0 > H - FOOTER_PT - 8

    # text off the page, or in the footer band
    for s in spans:
        if s.x0 < -TOL or s.y0 < -TOL or s.x1 > W + TOL or s.y1 > H + TOL:
            out.append(Defect(number, "off-page", f"{_short(s.text)} runs off the page"))
        elif has_footer and not s.footer and s.y1 > H - FOOTER_PT + TOL:
            out.append(Defect(number, "off-page", f"{_short(s.text)} runs into the footer"))

    # text over text
    order = sorted(range(len(spans)), key=lambda i: spans[i].x0)
    for a_i, i in enumerate(order):
        a = spans[i]
        for j in order[a_i + 1:]:
            b = spans[j]
            if b.x0 >= a.x1 - TOL:
                break
            ox, oy = _overlap(a, b)
            if ox > TOL and oy > TOL:
                out.append(Defect(number, "text-overlap", f"{_short(a.text)} and {_short(b.text)} overlap"))

    # table cells: stroked and filled rectangles (matplotlib's table); text crossing its cell
    cells = [d["rect"] for d in drawings
             if d.get("type") == "fs" and d["items"] and all(it[0] == "re" for it in d["items"])
             and d["rect"].width > 4 and d["rect"].height > 4]
    for s in spans:
        # its cell: the one it overlaps most (a right-aligned value spilling left has its centre
        # outside its own cell)
        home = [(max(_overlap(s, r)[0], 0.0) * max(_overlap(s, r)[1], 0.0), r) for r in cells]
        home = [(a, r) for a, r in home if a > 0]
        if home:
            r = max(home, key=lambda ar: (ar[0], -ar[1].width * ar[1].height))[1]
            if not _inside(s, r, tol=0.5):
                out.append(Defect(number, "cell-overflow", f"{_short(s.text)} crosses its table cell"))

    # legends: stroked, filled rounded boxes (lines and curves) of some size
    legends = [d for d in drawings
               if d.get("type") == "fs" and {it[0] for it in d["items"]} >= {"l", "c"}
               and d["rect"].width > 15 and d["rect"].height > 8]
    panels = [d for d in drawings
              if d.get("type") == "f" and len(d["items"]) == 1 and d["items"][0][0] == "re"
              and d.get("fill") == (1.0, 1.0, 1.0) and d["rect"].width < W - 2
              and d["rect"].width > 40 and d["rect"].height > 40]
    for leg in legends:
        r, q = leg["rect"], leg["seqno"]
        inner = type(r)(r.x0 + 1.5, r.y0 + 1.5, r.x1 - 1.5, r.y1 - 1.5)
        for s in spans:
            ox, oy = _overlap(s, r)
            if ox <= TOL or oy <= TOL:
                continue
            if s.seqno < q:
                out.append(Defect(number, "under-legend", f"{_short(s.text)} is under a legend"))
            elif not _inside(s, r):
                out.append(Defect(number, "under-legend", f"{_short(s.text)} crosses a legend's box"))
        # data drawn before the legend with points inside its box: markers, curve vertices
        # (grid and reference lines end at the panel's edges, so have no point inside)
        # the panel the legend sits in: its background is drawn before it
        host = [p for p in panels if p["seqno"] < q and _contains_point(p["rect"], r.x0 + 1, r.y0 + 1)]
        start = max((p["seqno"] for p in host), default=-1)
        hidden = 0
        for d in drawings:
            if not start < d["seqno"] < q or d is leg:
                continue
            b = d["rect"]             # no point of d inside the box unless its bounds meet it
            if b.x1 < inner.x0 or b.x0 > inner.x1 or b.y1 < inner.y0 or b.y0 > inner.y1:
                continue
            if any(_contains_point(inner, x, y) for x, y in _points(d)):
                hidden += 1
        if hidden:
            out.append(Defect(number, "under-legend",
                              f"a legend at ({r.x0:.0f}, {r.y0:.0f}) pt covers {hidden} drawn data item(s)"))

    # text crossing the edge of a panel it partly lies in
    for p in panels:
        r = p["rect"]
        for s in spans:
            ox, oy = _overlap(s, r)
            if ox > 2 and oy > 2 and not _inside(s, r, tol=2):
                # crossing by more than 2 pt: not a tick label beside its axis
                out.append(Defect(number, "panel-overlap", f"{_short(s.text)} crosses a panel's edge"))
    return _unique(out)


def _unique(defects):
    seen, out = set(), []
    for d in defects:
        if (d.kind, d.text) not in seen:
            seen.add((d.kind, d.text))
            out.append(d)
    return out


def check_pdf(path) -> list[Defect]:
    """All layout defects of the PDF at ``path`` (an empty list: every page legible)."""
    import pymupdf
    out: list[Defect] = []
    with pymupdf.open(str(Path(path))) as doc:
        for i, page in enumerate(doc, start=1):
            out += check_page(page, i)
    return out


def pdf_git_hash(path) -> str:
    """The git hash in a report's PDF Keywords (``git <hash>``, nld.output.report.Report.metadata;
    '' when absent), with '+dirty' when the report was made from a tree with changes."""
    import pymupdf
    with pymupdf.open(str(Path(path))) as doc:
        kw = (doc.metadata or {}).get("keywords") or ""
    for part in kw.split(";"):
        part = part.strip()
        if part.startswith("git "):
            return part[4:].strip()
    return ""


if __name__ == "__main__":       # python -m nld.output.layout_check reports/*.pdf
    import sys
    bad = 0
    for f in sys.argv[1:]:
        ds = check_pdf(f)
        bad += bool(ds)
        print(f"{f}: {len(ds)} defect(s), pages {sorted({d.page for d in ds})}")
        for d in ds:
            print("   ", d)
    sys.exit(1 if bad else 0)
