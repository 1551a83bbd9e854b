"""Plots shared by the studies: Poincaré sections, bifurcation diagrams, exponent convergence and
spectra. Every function returns a :class:`matplotlib.figure.Figure` (built without pyplot, so no
display or backend is needed; save it with ``fig.savefig`` or ``PdfPages.savefig(fig)``) and
labels its axes with units (SI, from the column names: :func:`unit_of`). Pass ``ax=`` to draw
into an existing axes instead (its figure is returned).
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

__all__ = ["unit_of", "label_of", "poincare_scatter", "bifurcation_diagram",
           "exponent_convergence", "spectrum_plot", "figure_axes", "basin_fractions"]

DIRECTION_COLOURS = {"up": "tab:blue", "down": "tab:orange"}

_SUFFIX_UNITS = {
    "x": "m", "y": "m", "theta": "rad", "vx": "m/s", "vy": "m/s", "omega": "rad/s",
    "ax": "m/s²", "ay": "m/s²", "alpha": "rad/s²", "ex": "m", "ey": "m", "eccentricity": "m",
    "penetration": "m", "penetration_rate": "m/s", "Fn": "N", "Ft": "N", "slip": "m/s",
    "contact": "-", "angle": "rad", "speed": "rad/s", "torque": "N m", "kinetic": "J",
    "potential": "J", "total": "J", "driver": "W", "loads": "W", "clearance": "m",
    "journal_radius": "m", "mass": "kg", "inertia": "kg m²", "mu": "-", "restitution": "-",
    "exponent": "-", "v0": "m/s", "v1": "m/s", "damping": "N s/m", "stiffness": "N/m^n",
    "young": "Pa", "poisson": "-", "torque_slope": "N m s/rad", "angle0": "rad", "value": "",
    "free_length": "m", "threshold": "rad", "min_approach_velocity": "m/s",
    "tangential_damping": "N s/m",
}


def unit_of(name: str) -> str:
    """SI unit of a table column or a scene key (``B.ex`` -> m, ``driver.speed`` -> rad/s,
    ``joints.B.friction.mu`` -> -, ``t`` -> s); "" when unknown (e.g. an undotted ODE state name)."""
    if name == "t":
        return "s"
    parts = str(name).split(".")
    if len(parts) < 2:          # not a table column or scene key (an ODE state): unknown
        return ""
    if parts[0] == "scene" and len(parts) > 1 and parts[1] == "gravity":
        return "m/s²"
    for p in reversed(parts):
        if p.isdigit():
            continue
        return _SUFFIX_UNITS.get(p, "")
    return ""


def label_of(name: str, unit: str | None = None) -> str:
    """``"B.ex (m)"``."""
    u = unit_of(name) if unit is None else unit
    return f"{name} ({u})" if u else name


def figure_axes(ax, figsize=(6.4, 4.8)):
    """``(figure, axes)``: those of ``ax`` if given, else a new matplotlib Figure (no pyplot) of
    ``figsize`` inches with one subplot."""
    if ax is not None:
        return ax.figure, ax
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.add_subplot()


def poincare_scatter(section, x: str | None = None, y: str | None = None, *, ax=None,
                     title: str | None = None, s: float = 4.0, color=None, scale: float = 1.0,
                     unit: str | None = None, label: str | None = None):
    """Scatter of section points, ``y`` against ``x`` (default the first two observables).

    section: a :class:`nld.analysis.poincare.Section` or a table with the observable columns.
    scale, unit: plot x and y times ``scale`` with that unit in the labels (e.g. ``scale=1e3,
    unit="mm"`` for journal eccentricities); default SI.
    """
    table = section.table if hasattr(section, "table") else section
    obs = list(section.observables) if hasattr(section, "observables") else \
        [c for c in table.columns if c not in ("rev", "crossing", "t", "value", "direction",
                                               "index", "period", "lyapunov",
                                               "lyapunov_uncertainty", "status", "message")]
    x = x or obs[0]
    y = y or (obs[1] if len(obs) > 1 else obs[0])
    fig, ax = figure_axes(ax)
    ax.scatter(table[x].to_numpy() * scale, table[y].to_numpy() * scale, s=s, c=color,
               label=label, linewidths=0)
    ax.set_xlabel(label_of(x, unit))
    ax.set_ylabel(label_of(y, unit))
    if x.endswith(".ex") and y.endswith(".ey"):
        ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(title if title is not None else f"Poincaré section ({len(table)} points)")
    if label:
        ax.legend()
    return fig


def bifurcation_diagram(table: pd.DataFrame, observable: str | None = None, *, param: str | None = None,
                        ax=None, title: str | None = None, s: float = 1.5, scale: float = 1.0,
                        unit: str | None = None, param_scale: float = 1.0,
                        param_unit: str | None = None):
    """Parameter value against the section points of one observable (a :func:`nld.analysis.bifurcation.sweep`
    or ``load_sweep`` table), coloured by direction (up: blue, down: orange); failed points are
    marked by red crosses on the lower axis. param: the swept key, for the label (default from
    ``table.attrs["provenance"]``). scale/unit, param_scale/param_unit: plot scaling and units.
    """
    prov = table.attrs.get("provenance", {}) if hasattr(table, "attrs") else {}
    param = param or prov.get("param") or "value"
    if observable is None:
        skip = {"value", "direction", "index", "rev", "period", "lyapunov",
                "lyapunov_uncertainty", "status", "message"}
        observable = next(c for c in table.columns if c not in skip)
    fig, ax = figure_axes(ax)
    ok = table[table["status"] == "ok"] if "status" in table.columns else table
    dirs = ok["direction"].unique() if "direction" in ok.columns else [None]
    for d in dirs:
        part = ok[ok["direction"] == d] if d is not None else ok
        ax.scatter(part["value"].to_numpy(dtype=float) * param_scale,
                   part[observable].to_numpy(dtype=float) * scale, s=s, linewidths=0,
                   color=DIRECTION_COLOURS.get(d, "k"), label=f"sweep {d}" if d else None)
    if "status" in table.columns:
        bad = table[table["status"] != "ok"].drop_duplicates(["direction", "index"])
        if len(bad):
            ax.plot(bad["value"].to_numpy(dtype=float) * param_scale, np.zeros(len(bad)), "x",
                    color="tab:red", transform=ax.get_xaxis_transform(), clip_on=False,
                    label=f"failed ({len(bad)})")
    ax.set_xlabel(label_of(param, param_unit))
    ax.set_ylabel(label_of(observable, unit))
    ax.set_title(title if title is not None else f"Bifurcation diagram: {observable} vs {param}")
    if len(dirs) > 1 or ("status" in table.columns and (table["status"] != "ok").any()):
        ax.legend(markerscale=4)
    return fig


def exponent_convergence(result=None, *, times=None, history=None, uncertainty=None,
                         units: str = "1/s", per_revolution: bool = False, period: float | None = None,
                         ax=None, title: str | None = None, labels=None):
    """Running Lyapunov estimate(s) against averaging time, with the final estimate +- its
    uncertainty as a band.

    result: a ``nld.analysis.lyapunov`` LyapunovResult / SpectrumResult (``times``, ``history``,
    ``uncertainty``, ``units``, ``period``); or give times (s), history (n,) or (n, k) and
    uncertainty. per_revolution: x in revolutions and exponents per revolution (needs a period).
    """
    if result is not None:
        times = result.times if times is None else times
        history = result.history if history is None else history
        uncertainty = result.uncertainty if uncertainty is None else uncertainty
        units = getattr(result, "units", units)
        period = getattr(result, "period", period) if period is None else period
    t = np.asarray(times, dtype=float)
    H = np.asarray(history, dtype=float)
    if H.ndim == 1:
        H = H[:, None]
    U = np.broadcast_to(np.asarray(uncertainty if uncertainty is not None else 0.0, dtype=float),
                        (H.shape[1],))
    time_unit = units.split("/")[-1] if "/" in units else "s"
    xlabel, ylabel = f"averaging time ({time_unit})", f"Lyapunov exponent ({units})"
    if per_revolution:
        if not period:
            raise ValueError("per_revolution needs a period")
        t, H, U = t / period, H * period, U * period
        xlabel, ylabel = "averaging time (revolutions)", "Lyapunov exponent (1/revolution)"
    fig, ax = figure_axes(ax)
    for k in range(H.shape[1]):
        lab = (labels[k] if labels is not None else (f"λ{k + 1}" if H.shape[1] > 1 else "λ1"))
        line, = ax.plot(t, H[:, k], lw=1.2, label=lab)
        fin = H[-1, k]
        ax.axhspan(fin - U[k], fin + U[k], color=line.get_color(), alpha=0.2, lw=0)
        ax.axhline(fin, color=line.get_color(), lw=0.6, ls="--")
    ax.axhline(0.0, color="0.5", lw=0.6)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title if title is not None else "Convergence of the Lyapunov exponent"
                 + ("s" if H.shape[1] > 1 else "") + " (band: final ± uncertainty)")
    ax.legend()
    return fig


def spectrum_plot(spec: pd.DataFrame, *, ax=None, title: str | None = None, log: bool = True,
                  max_order: float | None = 20.0, orders=None, peaks: pd.DataFrame | None = None,
                  unit: str | None = None):
    """Power spectral density against frequency (Hz), crank harmonics marked.

    spec: a :func:`nld.analysis.spectrum.spectrum` table (crank frequency in ``attrs``). Harmonic orders
    1, 2, ... up to ``max_order`` (or the given ``orders``) are dotted vertical lines and a top axis
    reads in orders; the x range stops at max_order (None: Nyquist). peaks: a
    :func:`nld.analysis.spectrum.peaks` table, marked with dots. unit: the signal's unit (default from
    ``attrs["observable"]``), so the density is in unit²/Hz.
    """
    a = spec.attrs
    fc = a.get("crank_frequency")
    obs = a.get("observable")
    u = unit if unit is not None else (unit_of(obs) if obs else "")
    f = spec["freq_hz"].to_numpy()
    p = spec["power"].to_numpy()
    fig, ax = figure_axes(ax)
    sel = f > 0 if log else np.ones_like(f, dtype=bool)
    ax.plot(f[sel], p[sel], lw=0.9, color="k")
    if log:
        ax.set_yscale("log")
    fmax = f[-1]
    if fc and max_order is not None:
        fmax = min(fmax, max_order * fc)
    ax.set_xlim(0.0, fmax)
    if fc:
        ords = orders if orders is not None else range(1, int(math.floor(fmax / fc)) + 1)
        for k in ords:
            ax.axvline(k * fc, color="tab:blue", lw=0.6, ls=":", alpha=0.8)
        top = ax.secondary_xaxis("top", functions=(lambda x: x / fc, lambda o: o * fc))
        top.set_xlabel(f"order of the crank frequency ({fc:.4g} Hz)")
    if peaks is not None and len(peaks):
        ax.plot(peaks["freq_hz"], peaks["power"], "o", ms=4, color="tab:red", label="peaks")
        ax.legend()
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"power spectral density ({u}²/Hz)" if u else "power spectral density (1/Hz)")
    res = a.get("resolution_hz", float("nan"))
    desc = f"{a.get('method', '')}, {a.get('window', '')} window, Δf = {res:.3g} Hz"
    ax.set_title(title if title is not None else f"Spectrum{' of ' + obs if obs else ''} ({desc})")
    return fig


BIFURCATION_MARKERS = {"period_doubling": ("o", "PD"), "fold": ("s", "fold"),
                       "neimark_sacker": ("D", "NS"), "grazing": ("^", "grazing"),
                       "contact_change": ("v", "contact change")}


def branch_diagram(curves, observable: str, param: str, *, sweep: pd.DataFrame | None = None,
                   ax=None, title: str | None = None, scale: float = 1.0, unit: str | None = None,
                   param_scale: float = 1.0, param_unit: str | None = None):
    """Continued periodic-orbit branches in the plane (parameter, observable at the section
    points): stable stretches solid, unstable dashed, undecided dotted; located bifurcations marked
    and named. curves: ``nld.analysis.continuation.branch_curves`` (per branch: period, values,
    y (n_values, period), stable, bifurcations as (kind, value, y)). sweep: a brute-force
    bifurcation table of the same parameter (``nld.analysis.bifurcation.sweep``) drawn underneath
    in grey."""
    fig, ax = figure_axes(ax)
    if sweep is not None and len(sweep) and observable in sweep.columns:
        ok = sweep[sweep["status"] == "ok"] if "status" in sweep.columns else sweep
        ax.scatter(ok["value"].to_numpy(dtype=float) * param_scale,
                   ok[observable].to_numpy(dtype=float) * scale, s=1.5, linewidths=0,
                   color="0.6", label="brute force (section points)")
    styles = {True: ("-", "stable"), False: ("--", "unstable"), None: (":", "undecided")}
    shown = set()
    for c in curves:
        vals, ys, stab = np.asarray(c["values"], dtype=float), np.asarray(c["y"]), c["stable"]
        colour = f"C{(c['period'] - 1) % 10}"
        for k in range(ys.shape[1] if ys.ndim == 2 else 0):
            i = 0
            while i < len(vals) - 1:
                j = i
                while j + 1 < len(vals) and stab[j + 1] == stab[i]:
                    j += 1
                ls, lab = styles[stab[i]]
                seg = slice(i, min(j + 2, len(vals)))
                key = (c["period"], lab)
                ax.plot(vals[seg] * param_scale, ys[seg, k] * scale, ls, color=colour, lw=1.4,
                        label=f"period {c['period']}, {lab}" if key not in shown else None)
                shown.add(key)
                i = j + 1
        for kind, value, yb in c["bifurcations"]:
            mk, short = BIFURCATION_MARKERS.get(kind, ("x", kind))
            yb = np.atleast_1d(yb)
            ax.plot(np.full(yb.size, value * param_scale), yb * scale, mk, color="k", ms=6,
                    mfc="none", label=short if short not in shown else None)
            shown.add(short)
            ax.annotate(f"{short} {value * param_scale:.4g}", (value * param_scale, yb[0] * scale),
                        textcoords="offset points", xytext=(4, 6), fontsize=7)
    ax.set_xlabel(label_of(param, param_unit))
    ax.set_ylabel(label_of(observable, unit))
    ax.set_title(title if title is not None else f"Periodic-orbit branches: {observable}")
    if shown:
        ax.legend(fontsize=7)
    return fig


def basin_fractions(table: pd.DataFrame, param: str, *, title: str | None = None,
                    param_scale: float = 1.0, param_unit: str | None = None,
                    period_name: str = "revolution"):
    """Basin fractions stacked against a parameter, one colour per attractor (its label kept
    across the values), unsettled runs in grey; beside it λ1 of each attractor with its
    uncertainty. table: ``nld.analysis.attractors.match_attractors`` (value, label, kind,
    fraction, lambda1, lambda1_uncertainty). Returns the Figure (two axes)."""
    from matplotlib.figure import Figure
    fig = Figure(figsize=(9.6, 4.2), layout="constrained")
    ax, bx = fig.subplots(1, 2)
    t = table[table["label"] >= -1]
    vals = np.sort(t["value"].unique())
    x = vals * param_scale
    labels = sorted(int(v) for v in t["label"].unique() if v >= 0) + \
        ([-1] if (t["label"] == -1).any() else [])
    bottom = np.zeros(vals.size)
    for lab in labels:
        g = t[t["label"] == lab]
        f = np.array([float(g[g["value"] == v]["fraction"].sum()) for v in vals])
        kinds = ", ".join(sorted(set(g["kind"])))
        colour = "0.75" if lab < 0 else f"C{lab % 10}"
        name = "unsettled" if lab < 0 else f"#{lab} {kinds}"
        width = 0.8 * (float(np.min(np.diff(x))) if x.size > 1 else 1.0)
        ax.bar(x, f, width=width, bottom=bottom, color=colour, alpha=0.9, label=name, lw=0)
        bottom += f
        if lab >= 0:
            ok = g[np.isfinite(g["lambda1"].to_numpy(dtype=float))]
            bx.errorbar(ok["value"].to_numpy(dtype=float) * param_scale,
                        ok["lambda1"].to_numpy(dtype=float),
                        yerr=ok["lambda1_uncertainty"].to_numpy(dtype=float), fmt="o-",
                        color=colour, ms=3, capsize=2, label=name)
    if param_unit is None:
        param_unit = unit_of(param) or None
    xl = param + (f" [{param_unit}]" if param_unit else "")
    ax.set_xlabel(xl)
    if vals.size > 1:
        lo, hi = float(x.min()), float(x.max())
        pad = 0.5 * (hi - lo) / (vals.size - 1)
        ax.set_xlim(lo - pad, hi + pad)
        bx.set_xlim(lo - pad, hi + pad)
    for a in (ax, bx):
        a.ticklabel_format(axis="x", style="sci", scilimits=(-3, 4))
    ax.set_ylabel("basin fraction")
    ax.set_ylim(0, 1)
    ax.legend(fontsize=7, loc="best")
    bx.axhline(0.0, color="0.5", lw=0.8)
    bx.set_xlabel(xl)
    bx.set_ylabel(f"λ1 [per {period_name}]")
    if title:
        fig.suptitle(title)
    return fig


# ---------------------------------------------------------------------------------- page layout
# Used by nld.output.report.Report.figure on every figure page: titles and labels that would run
# past their panel are split into lines, and a legend that covers data is moved to a free corner
# of its panel or, when there is none, under the panel (outside the data).

_LEGEND_LOCS = ("upper right", "upper left", "lower left", "lower right", "center right",
                "center left", "upper center", "lower center", "center")


def renderer(fig):
    """matplotlib's Agg renderer of ``fig`` (text extents are measured with it)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    return fig.canvas.get_renderer()


def fit_texts(fig) -> bool:
    """Split panel titles, axis labels and the figure title that are longer than their panel
    (the page) into lines at sensible points (``nld.output.text.split_value``); legend entries wider than
    their panel too. True when a text was changed (the layout is then to be redone)."""
    from nld.output.text import split_value
    r = renderer(fig)
    changed = False

    def fit(t, room_px, vertical=False):
        nonlocal changed
        s = t.get_text()
        if not s or not t.get_visible() or "$" in s:
            return
        e = t.get_window_extent(r)
        size = e.height if vertical else e.width
        if size <= room_px * 1.001:
            return
        longest = max(s.split("\n"), key=len)
        chars = max(14, int(len(longest) * room_px / size * 0.95))
        new = "\n".join(split_value(s, chars))
        if new != s:
            t.set_text(new)
            changed = True

    for ax in [a for ax0 in fig.axes for a in (ax0, *getattr(ax0, "child_axes", []))]:
        if not ax.get_visible() or not ax.axison:
            continue
        bb = ax.get_window_extent(r)
        room = bb.width                 # a title may use its panel's grid cell (square panels)
        ss = ax.get_subplotspec() if hasattr(ax, "get_subplotspec") else None
        if ss is not None:
            gs = ss.get_gridspec()
            ncols = gs.get_geometry()[1]
            span = ss.colspan.stop - ss.colspan.start
            room = max(room, 0.9 * fig.bbox.width * span / ncols * 0.9)
        for t in (ax.title, getattr(ax, "_left_title", None), getattr(ax, "_right_title", None)):
            if t is not None:
                fit(t, room)
        fit(ax.xaxis.label, bb.width)
        fit(ax.yaxis.label, bb.height, vertical=True)
        leg = ax.get_legend()
        if leg is not None:
            for t in leg.get_texts():
                fit(t, 0.8 * bb.width)
    sup = getattr(fig, "_suptitle", None)
    if sup is not None:
        fit(sup, fig.bbox.width * 0.9)
    return changed


def _data_points(ax):
    """``[(points, radius)]``: display coordinates (pixels) of what an axes draws (line vertices,
    markers and collection offsets, patch corners) with the radius of their markers (pixels)."""
    px = ax.figure.dpi / 72.0
    out = []
    for ln in ax.lines:
        if ln.get_visible() and len(ln.get_xydata()):
            m = ln.get_marker()
            rad = 0.5 * ln.get_markersize() * px if m not in (None, "None", "", " ", ",") else 0.0
            out.append((ln.get_transform().transform(ln.get_xydata()), rad))
    for c in ax.collections:
        if not c.get_visible():
            continue
        off = c.get_offsets()
        sizes = c.get_sizes() if hasattr(c, "get_sizes") else []
        rad = 0.5 * math.sqrt(float(np.max(sizes))) * px if len(sizes) else 0.0
        if off is not None and len(off):
            out.append((c.get_offset_transform().transform(np.asarray(off, dtype=float)), rad))
        tr = c.get_transform()
        for p in c.get_paths()[:2000]:
            if len(p.vertices) and (off is None or len(off) <= 1):
                out.append((tr.transform(p.vertices), 0.0))
    for p in ax.patches:
        if p.get_visible():
            out.append((p.get_transform().transform(p.get_path().vertices), 0.0))
    return [(q, r) for q, r in out if q.ndim == 2 and q.shape[1] == 2]


def _covered(bb, pts, text_boxes, pad: float) -> int:
    n = 0
    for q, rad in pts:
        x0, y0, x1, y1 = bb.x0 + pad - rad, bb.y0 + pad - rad, bb.x1 - pad + rad, bb.y1 - pad + rad
        p = q[np.isfinite(q).all(axis=1)]
        n += int(((p[:, 0] > x0) & (p[:, 0] < x1) & (p[:, 1] > y0) & (p[:, 1] < y1)).sum())
    x0, y0, x1, y1 = bb.x0 + pad, bb.y0 + pad, bb.x1 - pad, bb.y1 - pad
    for t in text_boxes:
        if min(x1, t.x1) > max(x0, t.x0) and min(y1, t.y1) > max(y0, t.y0):
            n += 1
    return n


def place_legends(fig) -> list:
    """Move every panel legend that covers data (a line vertex, marker or text under its box) to
    a corner of the panel where it covers none. Legends with no free corner are taken off their
    panel: returned as ``[(handle, label), ...]`` for one legend of the figure, under the panels
    (:func:`figure_legend`)."""
    r = renderer(fig)
    px_per_pt = fig.dpi / 72.0
    out = []
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None or not leg.get_visible():
            continue
        axbb = ax.get_window_extent(r)
        bb = leg.get_window_extent(r)
        inside = (bb.x0 >= axbb.x0 - 1 and bb.x1 <= axbb.x1 + 1 and bb.y0 >= axbb.y0 - 1
                  and bb.y1 <= axbb.y1 + 1)
        if not inside:
            continue
        pts = _data_points(ax)
        texts = [t.get_window_extent(r) for t in ax.texts if t.get_visible() and t.get_text()]
        pad = 1.5 * px_per_pt
        if _covered(bb, pts, texts, pad) == 0:
            continue
        done = False
        for loc in _LEGEND_LOCS:
            leg.set_loc(loc)
            b = leg.get_window_extent(r)
            if (b.x0 >= axbb.x0 and b.x1 <= axbb.x1 and b.y0 >= axbb.y0 and b.y1 <= axbb.y1
                    and _covered(b, pts, texts, pad) == 0):
                done = True
                break
        if not done:
            mine = dict(zip(*ax.get_legend_handles_labels()[::-1]))
            for h, t in zip(leg.legend_handles, leg.get_texts()):
                lab = t.get_text()
                out.append((mine.get(lab.replace("\n", " "), mine.get(lab, h)), lab.replace("\n", " ")))
            leg.remove()
    return out


def figure_legend(fig, entries, bottom: float, size: float = 7.5):
    """One legend of the figure from ``entries`` [(handle, label)] (the same label once), centred
    under the panels with its lower edge at ``bottom`` (figure fraction), in as many columns as the
    page's width holds; returns its height as a figure fraction."""
    seen, handles, labels = set(), [], []
    for h, lab in entries:
        if lab not in seen:
            seen.add(lab)
            handles.append(h)
            labels.append(lab)
    old = getattr(fig, "_nld_legend", None)
    if old is not None:
        old.remove()
    r = renderer(fig)
    ncol = len(labels)
    while True:
        leg = fig.legend(handles, labels, loc="lower center", bbox_to_anchor=(0.5, bottom), ncols=max(ncol, 1),
                         fontsize=size, frameon=False)
        w = leg.get_window_extent(r).width
        if ncol <= 1 or w <= 0.92 * fig.bbox.width:
            break
        leg.remove()
        ncol -= 1
    fig._nld_legend = leg
    return leg.get_window_extent(r).height / fig.bbox.height
