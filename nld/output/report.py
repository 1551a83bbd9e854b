"""Multi-page PDF reports of studies (matplotlib ``PdfPages``), with their provenance.

    from nld.output.report import Report, save_study_data

    with Report("reports/x.pdf", "My study", scene="excavator", provenance=prov,
                settings={"rtol": 1e-7, "revolutions": "1 transient + 3 plotted"}) as rep:
        rep.text_page("Summary", ["First paragraph.", "- a bullet", "- another"])
        fig, axes = rep.subplots(1, 2, title="Rod angular velocity")
        ...                                   # plot, label axes with units
        rep.figure(fig, caption="What the figure shows.")
        rep.table("Peak values", df, col_units={"omega": "rad/s"})
    save_study_data({"case1": df1, "case2": df2}, "reports/x.parquet", prov)

Layout: every page is A4 landscape (:data:`PAGE_SIZE`); the first page(s) are the title page with
the scene name, every scene parameter with its unit (:func:`nld.model.scene.format_scene`), the method,
tolerances and other settings, the nld version, the git hash, the date and the wall time. Every
page has a footer with the report title, ``page i of N`` and the version/git hash. Pages are kept
in memory and written when the ``with`` block ends (the title page needs the total wall time and
the page count), to a temporary file renamed into place, so that a failed study leaves no partial
PDF behind.

Reproducibility: when the environment variable ``SOURCE_DATE_EPOCH`` is set, the date printed on
the title page is that time (UTC), matplotlib writes it as the PDF ``CreationDate``, and the wall
time is left out (the title page says so); two runs on the same data and source tree then give
byte-identical files. PDF metadata: Title, Author ``nld``, Subject, Keywords (with the git hash),
Creator.
"""
from __future__ import annotations

import datetime as _dt
import os
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd

from nld.output.text import split_value  # noqa: F401 (re-exported: report.split_value)

__all__ = ["PAGE_SIZE", "STYLE", "Report", "save_study_data", "source_date_epoch",
           "estimator_text", "study_started", "study_start"]

_STUDY_START: list = [None]


def study_started(t: float | None) -> None:
    """The ``time.perf_counter()`` at which the running study started (``nld study`` sets it), so
    that a Report's title page shows the study's whole wall time, not only the report's own."""
    _STUDY_START[0] = t


def study_start() -> float | None:
    """The ``time.perf_counter()`` set by :func:`study_started` (None outside ``nld study``): a
    study run directly passes its own start to Report, and this one where it is earlier."""
    return _STUDY_START[0]


def estimator_text(settings: dict | None, method: str | None = None, period: float | None = None) -> str:
    """One line naming the estimator of an exponent, its tolerance and averaging span, from the
    result's ``settings`` dict (``nld.analysis.lyapunov`` results: method, rtol, transient, total,
    renorm_interval, d0 ...), so the text follows the estimator that actually ran. Times are
    given in crank revolutions too when ``period`` (s) is known; keys that are absent are left
    out."""
    st = dict(settings or {})
    method = method or st.get("method") or st.get("estimator") or "?"
    parts = [f"estimator {method}"]
    if st.get("integrator") or st.get("system_method"):
        parts.append(f"integrator {st.get('integrator') or st.get('system_method')}")
    if st.get("rtol") is not None:
        parts.append(f"rtol {float(st['rtol']):g}")

    def span(v):
        v = float(v)
        if period:
            return f"{v / period:.3g} rev ({v:.3g} s)"
        return f"{v:.3g} s"
    if st.get("transient") is not None:
        parts.append(f"transient {span(st['transient'])}")
    if st.get("align"):
        parts.append(f"tangent vectors aligned over {span(st['align'])}")
    if st.get("total") is not None:
        parts.append(f"averaged over {span(st['total'])}")
    if st.get("renorm_interval") is not None:
        parts.append(f"renormalised every {span(st['renorm_interval'])}")
    if st.get("d0") is not None:
        parts.append(f"d0 {float(st['d0']):g}")
    if st.get("tangent_err") is False:
        parts.append("state-only error control")
    if st.get("n_blocks") is not None:
        parts.append(f"{st['n_blocks']} blocks for the uncertainty")
    return "; ".join(parts)

PAGE_SIZE = (11.69, 8.27)          # A4 landscape, inches
# readable in print at A4: 9-10 pt text, visible lines; TrueType fonts so that the text is searchable
STYLE = {
    "font.size": 9.5,
    "axes.titlesize": 10.5,
    "axes.labelsize": 9.5,
    "xtick.labelsize": 8.5,
    "ytick.labelsize": 8.5,
    "legend.fontsize": 8.5,
    "lines.linewidth": 1.1,
    "axes.grid": True,
    "grid.alpha": 0.35,
    "grid.linewidth": 0.5,
    "figure.titlesize": 12,
    "pdf.fonttype": 42,
    "ps.fonttype": 42,
}
_FOOTER_H = 0.045                  # figure fraction kept free for the footer
_TOP = 0.955                       # figure fraction below the page heading
_MARGIN = 0.045


def study_workers(default: int) -> int:
    """Worker processes of a study's sweeps: ``default`` (what the committed reports used), or
    the environment variable NLD_WORKERS (a whole number >= 1) to use a larger machine. The
    numbers do not depend on it (nld.analysis.bifurcation: local and Dask sweeps agree point for point)."""
    v = os.environ.get("NLD_WORKERS")
    if not v:
        return default
    try:
        n = int(v)
    except ValueError:
        n = 0
    if n < 1:
        from nld.errors import InputError
        raise InputError(f"NLD_WORKERS = {v!r}: must be a whole number >= 1")
    return n


def source_date_epoch() -> int | None:
    """``SOURCE_DATE_EPOCH`` as an int, or None when unset or empty; InputError (a ValueError) when
    it is not a whole number of seconds since 1970 between 0 and the end of year 9999."""
    v = os.environ.get("SOURCE_DATE_EPOCH", "").strip()
    if not v:
        return None
    from nld.errors import InputError
    try:
        n = int(v)
    except ValueError:
        raise InputError(f"SOURCE_DATE_EPOCH = {v!r}: must be a whole number of seconds since "
                         "1970-01-01 UTC (e.g. 1700000000), or unset") from None
    if not 0 <= n <= 253402300799:
        raise InputError(f"SOURCE_DATE_EPOCH = {v!r}: must be between 0 and 253402300799 "
                         "(seconds since 1970-01-01 UTC, up to the end of year 9999)")
    return n


def _fmt_cell(v, float_format) -> str:
    if v is None:
        return "–"
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        if not np.isfinite(v):
            return "–" if np.isnan(v) else str(v)
        if callable(float_format):
            return float_format(float(v))
        return float_format.format(float(v))
    return str(v)


def _new_figure(title: str | None = None):
    import matplotlib
    from matplotlib.figure import Figure
    with matplotlib.rc_context(STYLE):
        fig = Figure(figsize=PAGE_SIZE)
        if title:
            fig.suptitle(title, fontsize=13, fontweight="bold", x=_MARGIN, y=0.975, ha="left")
    return fig


_TABLE_BASE = 8.5      # table font size [pt] when the columns fit
_TABLE_MIN = 5.5       # smallest table font size [pt]
_TABLE_LINE = 1.25     # line height over font size in table cells
_TABLE_VPAD = 0.9      # vertical padding of a cell, in font sizes
_TABLE_HPAD = 0.5      # horizontal padding on each side of a cell, in font sizes


def _cell_lines(row) -> int:
    return max([str(s).count("\n") + 1 for s in row] or [1])


_WIDTHS: dict = {}


def _text_width(s: str, size: float, bold: bool = False) -> float:
    """Width [pt] of one line of text in the report font at ``size`` pt."""
    key = (s, bold)
    if key not in _WIDTHS:
        from matplotlib.font_manager import FontProperties
        from matplotlib.textpath import text_to_path
        prop = FontProperties(size=10.0, weight="bold" if bold else "normal")
        _WIDTHS[key] = text_to_path.get_text_width_height_descent(s, prop, ismath=False)[0] if s else 0.0
    return _WIDTHS[key] * size / 10.0


def _freeze_layout(fig) -> None:
    """Keep the panels where the last layout put them: the layout engine is removed before the page
    is written, so that saving does not run constrained layout again (its passes cost about a
    third of a page's rendering); an engine that cannot be removed (a colorbar made under it) stays."""
    import warnings
    if fig.get_layout_engine() is None:
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            fig.set_layout_engine("none")
        except (RuntimeError, ValueError):
            pass


def _wrap_measured(text: str, size: float, room: float) -> list[str]:
    """``text`` broken at spaces into lines no wider than ``room`` [pt] in the report font at
    ``size`` pt (measured, not counted: a line of digits and arrows is wider than one of letters);
    a single word wider than ``room`` is split at :func:`~nld.output.text.split_value`'s points."""
    out: list[str] = []
    for para in str(text).split("\n"):
        cur = ""
        for word in para.split(" "):
            trial = word if not cur else cur + " " + word
            if cur and _text_width(trial, size) > room:
                out.append(cur)
                cur = word
            else:
                cur = trial
            while _text_width(cur, size) > room and len(cur) > 1:
                parts = split_value(cur, max(1, int(len(cur) * room / _text_width(cur, size)) - 1))
                if len(parts) < 2:
                    break
                out.append(parts[0].rstrip())
                cur = "".join(parts[1:]).lstrip()
        out.append(cur)
    return out


def _fit_columns(header, body, room_w: float, col_widths=None):
    """``(header, body, widths, size)`` of a table ``room_w`` points wide that no cell text
    overflows: headers and then long values split at sensible points (:func:`split_value`) and the
    font shrunk (down to _TABLE_MIN) until every column holds its widest line; widths are fractions
    of the table width (``col_widths``, relative, are kept where they leave each column room)."""
    ncol = len(header)

    def need(h, b, size):
        w = []
        for c in range(ncol):
            lines = [(s, True) for s in h[c].split("\n")] + \
                    [(s, False) for r in b for s in str(r[c]).split("\n")]
            w.append(max(_text_width(s, size, bold) for s, bold in lines) + 2 * _TABLE_HPAD * size)
        return w

    def wrap_h(L):
        return [h if L is None else "\n".join(split_value(h, L)) for h in header]

    def wrap_b(L):
        return [[s if L is None else "\n".join(split_value(s, L)) for s in r] for r in body]

    tries = [(None, None), (16, None), (12, None), (10, None), (10, 32), (10, 24), (8, 18), (8, 12)]
    best = None
    for hl, bl in tries:
        h, b = wrap_h(hl), wrap_b(bl)
        n = need(h, b, _TABLE_BASE)
        size = min(_TABLE_BASE, _TABLE_BASE * room_w / max(sum(n), 1e-9))
        if best is None or size > best[3] + 1e-9:
            best = (h, b, n, size)
        if size >= 7.0:
            best = (h, b, n, size)
            break
    h, b, n, size = best
    size = max(size, _TABLE_MIN)
    n = [x * size / _TABLE_BASE for x in n]
    if col_widths is not None and len(col_widths) == ncol:
        tot = float(sum(col_widths)) or 1.0
        want = [max(room_w * float(x) / tot, m) for x, m in zip(col_widths, n)]
    else:
        spare = max(room_w - sum(n), 0.0)        # shared out evenly over the columns
        want = [m + spare / ncol for m in n]
    tot = sum(want) or 1.0
    return h, b, [x / tot for x in want], size


def _fit(text: str, room_pt: float, size: float) -> str:
    """``text`` cut (ending in '…') to at most ``room_pt`` points wide at font ``size`` [pt], so the
    footer's title never runs into the centred page number."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import text_to_path
    prop = FontProperties(size=size)

    def width(s: str) -> float:
        return text_to_path.get_text_width_height_descent(s, prop, ismath=False)[0]

    if width(text) <= room_pt:
        return text
    n = len(text)
    while n > 1 and width(text[:n].rstrip() + "…") > room_pt:
        n -= 1
    return text[:n].rstrip() + "…"


class Report:
    """A PDF report built page by page; use as a context manager (see the module docstring).

    path: the PDF file (parent directories are created). title: report title (title page, footer,
    PDF Title). scene: a Scene or a scene name/path (for the parameter listing), optional.
    provenance: dict as made by :func:`nld.run.simulate.provenance` (its ``integrator``, ``rtol`` and
    ``scene`` are shown when present), optional. settings: ``{label: value}`` shown on the title
    page (method, tolerances, revolutions, ...), optional. subtitle: a line under the title (e.g.
    "QUICK MODE"), shown in red when ``highlight_subtitle``. subject, keywords: PDF metadata.
    wall_time (s): shown on the title page; by default the time from the start of the study
    (:func:`study_started`, set by ``nld study``; else the construction of the Report) to the
    end of the ``with`` block. Set the attribute before the block ends to override.
    started: the ``time.perf_counter()`` at which the work reported on began (overrides
    :func:`study_started`).
    """

    def __init__(self, path, title: str, scene=None, provenance: dict | None = None,
                 settings: dict | None = None, *, subtitle: str | None = None,
                 highlight_subtitle: bool = False, subject: str | None = None,
                 keywords: list[str] | None = None, wall_time: float | None = None,
                 started: float | None = None):
        from nld.model.scene import load_scene
        self.path = Path(path)
        self.title = str(title)
        if isinstance(scene, (str, os.PathLike)):
            scene = load_scene(scene)
        self.scene = scene
        self.provenance = dict(provenance or {})
        self.settings = dict(settings or {})
        self.subtitle = subtitle
        self.highlight_subtitle = highlight_subtitle
        self.subject = subject
        self.keywords = list(keywords or [])
        self.wall_time = wall_time
        self._start = _STUDY_START[0] if _STUDY_START[0] is not None else time.perf_counter()
        if started is not None:
            self._start = float(started)
        self._pages: list = []          # Figures, in order (title pages are added at close)
        self._open = False

    # ------------------------------------------------------------------ context manager
    def __enter__(self) -> "Report":
        self._open = True
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc_type is None:
                self.close()
        finally:
            self._pages.clear()
            self._open = False
        return False

    # ------------------------------------------------------------------ pages
    def subplots(self, nrows: int = 1, ncols: int = 1, title: str | None = None, **kw):
        """``(fig, axes)``: a page-sized Figure in the report style (``axes`` as from plt.subplots)."""
        import matplotlib
        fig = _new_figure(title)
        with matplotlib.rc_context(STYLE):
            axes = fig.subplots(nrows, ncols, squeeze=kw.pop("squeeze", True), **kw)
        return fig, axes

    def figure(self, fig, caption: str | None = None) -> None:
        """Add a matplotlib Figure as one page (resized to the page; constrained layout unless it
        has a layout engine already, or panels placed by hand or a colorbar: tight layout then;
        titles and labels fitted to their panels and legends kept off the data, see
        :func:`nld.output.plots.fit_texts` and :func:`~nld.output.plots.place_legends`);
        ``caption``: text printed under the plots."""
        fig.set_size_inches(*PAGE_SIZE)
        bottom = _FOOTER_H + 0.01
        if caption:
            lines = _wrap_measured(caption, 8.5, PAGE_SIZE[0] * 72.0 * (1.0 - 2.0 * _MARGIN))
            bottom += 0.022 * len(lines) + 0.01
            fig.text(_MARGIN, _FOOTER_H + 0.012, "\n".join(lines), fontsize=8.5, va="bottom", ha="left",
                     linespacing=1.3)
        top = _TOP - 0.005 if fig.get_suptitle() else 0.985
        if fig.get_layout_engine() is None and not any(ax.get_subplotspec() is None
                                                       or ax.get_label() == "<colorbar>" for ax in fig.axes):
            # constrained layout: it places titles, labels, legends outside the panels and panels
            # of fixed aspect exactly (tight_layout's one pass left titles over the labels above)
            fig.set_layout_engine("constrained", h_pad=0.03, w_pad=0.03)
        engine = fig.get_layout_engine()

        def layout():
            top_ = top
            sup = getattr(fig, "_suptitle", None)
            if sup is not None and sup.get_text():       # a page title of two lines: panels below it
                from nld.output.plots import renderer
                sup.set_in_layout(False)
                top_ = min(top, sup.get_window_extent(renderer(fig)).y0 / fig.bbox.height - 0.012)
            if engine is None:
                import warnings
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", UserWarning)   # tight_layout's "not compatible"
                    fig.tight_layout(rect=(0.01, bottom, 0.99, top_))
            else:
                if hasattr(engine, "set") and "rect" in getattr(engine, "_params", {}):
                    engine.set(rect=(0.01, bottom, 0.98, top_ - bottom))  # keep the caption free
                fig.draw_without_rendering()
        # titles and labels longer than their panel are split into lines; a legend over data goes
        # to a free corner of its panel, or else into one legend of the figure under the panels
        # (nld.output.plots); the layout is redone after each change
        from nld.output.plots import figure_legend, fit_texts, place_legends
        fit_texts(fig)
        try:
            layout()
        except (ZeroDivisionError, ValueError, RuntimeError):
            # constrained layout cannot place some figures (a colorbar added to a grid it did
            # not make): tight_layout then, as before
            fig._layout_engine = None          # back to no engine (set_layout_engine refuses)
            engine = None
            layout()
        moved: list = []
        for _ in range(3):
            changed = fit_texts(fig)
            new = place_legends(fig)
            if new:
                moved += new
                h = figure_legend(fig, moved, bottom)
                bottom = min(bottom + h + 0.01, 0.6)
            if not (changed or new):
                break
            layout()
        else:                                  # the last layout moved the panels: legends again
            new = place_legends(fig)
            if new:
                moved += new
                bottom = min(bottom + figure_legend(fig, moved, bottom) + 0.01, 0.6)
                layout()
                place_legends(fig)
        _freeze_layout(fig)
        self._pages.append(fig)

    def text_page(self, title: str, paragraphs) -> None:
        """Pages of running text. ``paragraphs``: a string or a list of them; a paragraph starting
        with ``- `` is a bullet item; continuation pages are added when the text is long."""
        if isinstance(paragraphs, str):
            paragraphs = [paragraphs]
        lines = self._wrap(paragraphs, width=130)   # 145 ran past the right margin (0.955)
        per_page = 30
        chunks = [lines[i:i + per_page] for i in range(0, len(lines), per_page)] or [[]]
        for k, chunk in enumerate(chunks):
            fig = _new_figure(title if k == 0 else f"{title} (continued)")
            fig.text(_MARGIN, _TOP - 0.03, "\n".join(chunk), fontsize=10.5, va="top", ha="left",
                     linespacing=1.3)
            self._pages.append(fig)

    def table(self, title: str, data, col_units: dict | None = None, *, columns=None,
              notes=None, float_format="{:.4g}", rows_per_page: int = 24,
              col_widths=None) -> None:
        """A table page (continued over pages when long).

        data: a DataFrame, a list of dicts or a list of row sequences (then ``columns`` names them).
        col_units: ``{column: unit}``, printed in the header as ``column [unit]``. notes: text
        (string or list of paragraphs) under the table. Floats are printed with ``float_format``,
        NaN/None as ``–`` (``float_format`` may also be a function of the float returning the text). col_widths: relative column widths (default from the content).
        """
        if isinstance(data, pd.DataFrame):
            df = data
        elif data and isinstance(data[0], dict):
            df = pd.DataFrame(list(data))
        else:
            df = pd.DataFrame([list(r) for r in data], columns=columns)
        units = col_units or {}
        header = [f"{c}\n[{units[c]}]" if units.get(c) else str(c) for c in df.columns]
        body = [[_fmt_cell(v, float_format) for v in row] for row in df.itertuples(index=False)]
        room_w = (1 - 2 * _MARGIN) * PAGE_SIZE[0] * 72.0          # points across the page
        header, body, widths, size = _fit_columns(header, body, room_w, col_widths)
        note_lines = self._wrap([notes] if isinstance(notes, str) else list(notes or []), width=160)
        # rows per page: at most rows_per_page, and as many as the page's height holds
        line_pt = _TABLE_LINE * size
        head_pt = _cell_lines(header) * line_pt + _TABLE_VPAD * size
        row_pts = [_cell_lines(r) * line_pt + _TABLE_VPAD * size for r in body]
        room_h = (_TOP - 0.03 - _FOOTER_H - 0.02) * PAGE_SIZE[1] * 72.0
        chunks, cur, used = [], [], head_pt
        for r, h in zip(body, row_pts):
            note_pt = (0.021 * len(note_lines) + 0.02) * PAGE_SIZE[1] * 72.0
            if cur and (len(cur) >= rows_per_page or used + h > room_h - note_pt):
                chunks.append(cur)
                cur, used = [], head_pt
            cur.append(r)
            used += h
        chunks.append(cur)
        for k, chunk in enumerate(chunks):
            fig = _new_figure(title if k == 0 else f"{title} (continued)")
            last = k == len(chunks) - 1
            note_h = (0.021 * len(note_lines) + 0.02) if (last and note_lines) else 0.0
            ax_bottom = _FOOTER_H + 0.02 + note_h
            ax_h = _TOP - 0.03 - ax_bottom
            ax = fig.add_axes((_MARGIN, ax_bottom, 1 - 2 * _MARGIN, ax_h))
            ax.axis("off")
            heights = [head_pt] + [_cell_lines(r) * line_pt + _TABLE_VPAD * size for r in chunk]
            ax_pt = ax_h * PAGE_SIZE[1] * 72.0
            total = sum(heights) / ax_pt            # axes fraction; the bbox keeps the ratios
            tbl = ax.table(cellText=chunk if chunk else None, colLabels=header, colWidths=widths,
                           cellLoc="center", colLoc="center", loc="upper center",
                           bbox=(0.0, 1.0 - total, 1.0, total))
            tbl.auto_set_font_size(False)
            tbl.set_fontsize(size)
            for (r, c), cell in tbl.get_celld().items():
                cell.set_linewidth(0.4)
                cell.set_height(heights[r] / ax_pt)
                cell.PAD = _TABLE_HPAD * size / max(widths[c] * room_w, 1.0)
                cell.get_text().set_linespacing(_TABLE_LINE / 1.2)
                if r == 0:
                    cell.set_facecolor("#e6e6e6")
                    cell.set_text_props(fontweight="bold")
                elif r % 2 == 0:
                    cell.set_facecolor("#f7f7f7")
            if last and note_lines:
                fig.text(_MARGIN, _FOOTER_H + 0.015, "\n".join(note_lines), fontsize=8.5, va="bottom",
                         ha="left", linespacing=1.35)
            self._pages.append(fig)

    @staticmethod
    def style():
        """Context manager: the report's rcParams (:data:`STYLE`); make figures and plot inside it."""
        import matplotlib
        return matplotlib.rc_context(STYLE)

    def title_page_count(self) -> int:
        """Pages the title page takes (more than one when the scene parameters do not fit)."""
        pages = self._title_pages(source_date_epoch())
        for fig in pages:
            _release(fig)
        return len(pages)

    @property
    def page_count(self) -> int:
        """Pages added so far (the title page(s) not included)."""
        return len(self._pages)

    # ------------------------------------------------------------------ writing
    @staticmethod
    def _wrap(paragraphs, width: int) -> list[str]:
        out: list[str] = []
        for i, p in enumerate(paragraphs):
            p = str(p)
            if i and not (p.startswith("- ") and str(paragraphs[i - 1]).startswith("- ")):
                out.append("")
            if p.startswith("- "):
                out.extend(textwrap.wrap(p[2:], width=width - 3, initial_indent="•  ",
                                         subsequent_indent="   ", break_on_hyphens=False) or ["•"])
            else:
                out.extend(textwrap.wrap(p, width=width, break_on_hyphens=False) or [""])
        return out

    def _info_lines(self, epoch: int | None) -> list[tuple[str, str]]:
        from nld.version import __version__
        from nld.output.provenance import git_hash
        prov = self.provenance
        rows: list[tuple[str, str]] = []
        if self.scene is not None:
            src = f" ({Path(self.scene.source).name})" if getattr(self.scene, "source", "") else ""
            rows.append(("Scene", f"{self.scene.name}{src}"))
        elif prov.get("scene"):
            rows.append(("Scene", str(prov["scene"])))
        if prov.get("integrator"):
            rows.append(("Method", str(prov["integrator"])))
        if "rtol" in prov and "rtol" not in self.settings:
            rows.append(("rtol", f"{prov['rtol']:g}"))
        for k, v in self.settings.items():
            rows.append((str(k), _fmt_cell(v, "{:g}")))
        rows.append(("nld version", str(__version__)))
        rows.append(("git", git_hash()))
        if epoch is not None:
            date = _dt.datetime.fromtimestamp(epoch, _dt.timezone.utc)
            rows.append(("Date", date.strftime("%Y-%m-%d %H:%M UTC") + " (SOURCE_DATE_EPOCH)"))
            rows.append(("Wall time", "not shown: SOURCE_DATE_EPOCH is set (reproducible output)"))
        else:
            date = _dt.datetime.now(_dt.timezone.utc)
            rows.append(("Date", date.strftime("%Y-%m-%d %H:%M UTC")))
            wall = self.wall_time if self.wall_time is not None else time.perf_counter() - self._start
            rows.append(("Wall time", f"{wall:.1f} s (the whole run up to writing this PDF)"))
        return rows

    def _title_pages(self, epoch: int | None) -> list:
        from nld.model.scene import format_scene
        info = self._info_lines(epoch)
        params = format_scene(self.scene).splitlines() if self.scene is not None else []
        # the scene's name and file are in the Run block already
        params = [p for p in params if not p.startswith(("#", "scene.name =", "scene.source ="))]
        params = [w for line in params
                  for w in (textwrap.wrap(line, width=52, subsequent_indent="    ") or [""])]
        # lines per column: first page below a title of up to two lines and a subtitle, then more
        per_first, per_next, ncols_first, ncols_next = 48, 52, 2, 3
        title = textwrap.wrap(self.title, width=78) or [""]
        top = 0.955 - 0.042 * len(title) - 0.01 - (0.045 if self.subtitle else 0.0) - 0.015
        line_h = 8.3 * 1.5 / 72.0 / PAGE_SIZE[1]          # a Run line, figure fraction
        room = int(((top - 0.04) - (_FOOTER_H + 0.012)) / line_h)

        def run_lines(chars: int) -> list[str]:
            lw = min(max(len(a) for a, _ in info), 18)
            text = []
            for a, b in info:
                names = split_value(a, lw)
                vals = split_value(b, max(16, chars - lw - 2)) or [""]
                if max(len(v) for v in vals) > max(16, chars - lw - 2):    # a long hash or path:
                    text.append(a)                                        # under its name
                    text.extend("  " + v for v in split_value(b, chars - 2))
                    continue
                for i in range(max(len(names), len(vals))):
                    n = names[i] if i < len(names) else ""
                    v = vals[i] if i < len(vals) else ""
                    text.append(f"{n:<{lw}}  {v}".rstrip())
            return text

        run = run_lines(56)                    # the Run column: 0.045 to 0.385 of the width
        run_cols = [run]
        if len(run) > room:                    # too long beside the parameters: the Run block
            run = run_lines(74)                # takes the page in two columns, the parameters
            run_cols = [run[:room], run[room:2 * room]]      # follow on their own pages
            if len(run) > 2 * room:
                run_cols[-1] = run[room:2 * room - 1] + ["… (see the PDF metadata)"]
            per_first = 0
        cols = []
        rest = params
        first = True
        while rest:
            n = per_first * ncols_first if first else per_next * ncols_next
            cols.append(rest[:n])
            rest = rest[n:]
            first = False
        if not cols or per_first == 0:
            cols = [[]] + [c for c in cols if c]
        pages = []
        for k, chunk in enumerate(cols):
            fig = _new_figure()
            if k == 0:
                fig.text(_MARGIN, 0.955, "\n".join(title), fontsize=16, fontweight="bold", va="top",
                         ha="left", linespacing=1.2)
                if self.subtitle:
                    fig.text(_MARGIN, 0.955 - 0.042 * len(title) - 0.01, self.subtitle, fontsize=12.5,
                             va="top", ha="left",
                             color="#b00000" if self.highlight_subtitle else "black",
                             fontweight="bold" if self.highlight_subtitle else "normal")
                from nld.output.provenance import git_hash
                if "+dirty" in git_hash():
                    fig.text(1 - _MARGIN, 0.992, "made from a source tree with uncommitted changes "
                             "(git +dirty)", fontsize=9, va="top", ha="right", color="#b00000",
                             fontweight="bold")
                for c, part in enumerate(run_cols):
                    fig.text(_MARGIN + c * 0.47, top - 0.04, "\n".join(part), fontsize=8.3,
                             family="monospace", va="top", ha="left", linespacing=1.5)
                fig.text(_MARGIN, top, "Run", fontsize=11, fontweight="bold", va="top", ha="left")
                x0, ncol = 0.385, ncols_first
                head = "Scene parameters (SI units)" if (params and per_first) else ""
            else:
                fig.text(_MARGIN, 0.955, "Scene parameters (SI units" + (", continued)" if per_first else ")"),
                         fontsize=13, fontweight="bold", va="top", ha="left")
                top = 0.89
                x0, ncol = _MARGIN, ncols_next
                head = ""
            if head:
                fig.text(x0, top, head, fontsize=11, fontweight="bold", va="top", ha="left")
            width = (1 - _MARGIN - x0) / ncol
            per_col = per_first if k == 0 else per_next
            for c in range(ncol):
                part = chunk[c * per_col:(c + 1) * per_col]
                if part:
                    fig.text(x0 + c * width, top - 0.04, "\n".join(part), fontsize=6.3,
                             family="monospace", va="top", ha="left", linespacing=1.32)
            pages.append(fig)
        return pages

    def _footer(self, fig, i: int, n: int) -> None:
        from nld.version import __version__
        from nld.output.provenance import git_hash
        y = 0.018
        fig.text(_MARGIN, y, _fit(self.title, (0.5 - _MARGIN - 0.05) * fig.get_figwidth() * 72.0, 7.5),
                 fontsize=7.5, ha="left", va="bottom", color="#444444")
        fig.text(0.5, y, f"page {i} of {n}", fontsize=7.5, ha="center", va="bottom", color="#444444")
        h = git_hash()
        short = h[:12] + (" +dirty" if "+dirty" in h else "") + (" (NLD_GIT_HASH)" if "NLD_GIT_HASH" in h else "")
        fig.text(1 - _MARGIN, y, f"nld {__version__} · git {short}", fontsize=7.5,
                 ha="right", va="bottom", color="#444444")

    def metadata(self) -> dict:
        """The PDF document information dictionary written with the report."""
        from nld.version import __version__
        from nld.output.provenance import git_hash
        kw = ["nld", f"git {git_hash()}", f"nld {__version__}"]
        scene = self.scene.name if self.scene is not None else self.provenance.get("scene")
        if scene:
            kw.append(f"scene {scene}")
        kw += self.keywords
        import matplotlib
        return {"Title": self.title, "Author": "nld",
                "Subject": self.subject or (f"nld study of scene {scene}" if scene else "nld report"),
                "Keywords": "; ".join(kw),
                "Creator": f"nld {__version__} (nld.output.report, matplotlib {matplotlib.__version__})"}

    def close(self) -> Path:
        """Write the PDF (title page(s) first); returns its path. Called by the ``with`` block."""
        from matplotlib.backends.backend_pdf import PdfPages
        epoch = source_date_epoch()
        pages = self._title_pages(epoch) + self._pages
        n = len(pages)
        from nld.output.io import write_atomic
        import matplotlib

        def write(tmp):
            with matplotlib.rc_context(STYLE), PdfPages(tmp, metadata=self.metadata()) as pdf:
                png = os.environ.get("NLD_REPORT_PNG_DIR")      # page images, for reviewing
                for i, fig in enumerate(pages, start=1):
                    self._footer(fig, i, n)
                    pdf.savefig(fig)
                    if png:
                        Path(png).mkdir(parents=True, exist_ok=True)
                        fig.savefig(Path(png) / f"{self.path.stem}-{i:02d}.png", dpi=60)
                    _release(fig)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            write_atomic(self.path, write)       # the old PDF stays until the new one is whole
        except OSError as e:
            from nld.errors import InputError
            raise InputError(f"cannot write {self.path}: {e.strerror or e}") from None
        self.pages_written = n
        self._pages.clear()
        return self.path


def _release(fig) -> None:
    import sys
    if "matplotlib.pyplot" in sys.modules:     # figures made with pyplot are registered there
        sys.modules["matplotlib.pyplot"].close(fig)


def save_study_data(data, path, provenance: dict | None) -> Path:
    """Write a study's time series to ``path`` (``.parquet``; a ``.pdf`` path is changed to the
    ``.parquet`` beside it) with :func:`nld.output.io.save_table` and its provenance.

    data: a DataFrame, or ``{case: DataFrame}``; the frames of a dict are stacked (union of the
    columns, missing values NaN) with a leading ``case`` column holding the key.
    """
    p = Path(path)
    if p.suffix.lower() == ".pdf":
        p = p.with_suffix(".parquet")
    if isinstance(data, dict):
        frames = []
        for case, df in data.items():
            df = df.copy()
            if "case" in df.columns:
                df = df.drop(columns="case")
            df.insert(0, "case", str(case))
            frames.append(df)
        df = pd.concat(frames, ignore_index=True, sort=False) if frames else pd.DataFrame({"case": []})
    else:
        df = data
    from nld.output.io import save_table
    return save_table(df, p, provenance)


def ec_limit(*tables, floor: float = 1.15, columns=("B.ex/c", "B.ey/c")) -> float:
    """A common limit of e/c axes (eccentricity over clearance, dimensionless; +-1 = the journal
    touches the bearing): ``floor``, or 1.05 x the largest |e/c| in ``columns`` of the tables
    where the contact penetration takes the journal further (small clearances at high load), so
    that no section point is cut off."""
    m = [floor]
    for t in tables:
        for col in columns:
            if col in t.columns and len(t):
                v = np.abs(t[col].to_numpy(float))
                v = v[np.isfinite(v)]
                if v.size:
                    m.append(1.05 * float(v.max()))
    return max(m)
