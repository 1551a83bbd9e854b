"""Settings shared by the API and the command line, each default written once (issue 16).

Three frozen dataclasses, and one instance of each for every analysis that has its own defaults:

* :class:`Integration`: tolerance, method, step limit, output and event sampling of a run;
* :class:`Spans`: the transient and the measured span, in crank revolutions (periods);
* :class:`Renormalisation`: the re-orthonormalisation and stopping rule of the Lyapunov estimators.

The API functions take their keyword defaults from these instances (``stroboscopic(...,
rtol=SECTIONS.rtol)``), the command line its option defaults and their help text
(``nld poincare --rtol``), so the two cannot drift apart (tests/test_settings.py checks each shared
setting, and that the table of docs/analysis.md, :func:`defaults_table`, is current).

The range of a relative tolerance is checked in one place, :func:`check_rtol` (the API) and
:func:`rtol_in_range` (the command line and the scene file, which word their own errors).

A layer-0 module: it imports only nld.errors (itself importing nothing of nld).
"""
from __future__ import annotations

import numbers
from dataclasses import dataclass, fields

from nld.errors import InputError

__all__ = ["Integration", "Spans", "Renormalisation", "SIMULATE", "SECTIONS", "SPECTRUM",
           "LYAPUNOV", "POINCARE_SPANS", "BIFURCATION_SPANS", "SPECTRUM_SPANS", "CHAOS_MAP_SPANS",
           "TANGENT_SPANS", "BENETTIN_SPANS", "TANGENT", "BENETTIN", "defaults_table",
           "RTOL_RANGE", "RTOL_RANGE_TEXT", "rtol_in_range", "check_rtol"]

RTOL_RANGE = (1e-14, 1.0)
"""[low, high): the relative tolerances nld accepts (below 1e-14 the error control works at the
round-off of double precision; 1 or more controls nothing)"""
RTOL_RANGE_TEXT = "a number in [1e-14, 1)"


def rtol_in_range(rtol) -> bool:
    """True where ``rtol`` is a real number (a bool is not) in RTOL_RANGE."""
    if isinstance(rtol, bool) or not isinstance(rtol, numbers.Real):
        return False
    return RTOL_RANGE[0] <= float(rtol) < RTOL_RANGE[1]


def check_rtol(rtol, name: str = "rtol", *, none_ok: bool = False) -> float | None:
    """``rtol`` as a float, checked: :class:`nld.errors.InputError` "NAME = VALUE: must be a number
    in [1e-14, 1)" (" or None" where ``none_ok``, which lets None through) otherwise."""
    if rtol is None and none_ok:
        return None
    if not rtol_in_range(rtol):
        raise InputError(f"{name} = {rtol!r}: must be {RTOL_RANGE_TEXT}" + (" or None" if none_ok else ""))
    return float(rtol)



@dataclass(frozen=True)
class Integration:
    """How a trajectory is integrated."""

    rtol: float = 1e-8
    """relative tolerance of the adaptive step-size control (dimensionless; the absolute one is
    rtol x the state scales)"""
    method: str = "dopri5"
    """integrator: dopri5 (Dormand-Prince 5(4)), dop853 or rodas (Rosenbrock, experimental)"""
    max_steps: int = 50_000_000
    """steps allowed in one run; past them the run stops with a failure status"""
    samples_per_rev: int = 360
    """output rows per crank revolution (dense output; 1 degree of crank angle at 360)"""
    event_samples: int = 3
    """interior points of every step at which the event (contact) functions are sampled for sign
    changes (docs/integrator.md, "Events")"""


@dataclass(frozen=True)
class Spans:
    """How long: both spans in crank revolutions (periods of the system)."""

    transient_revs: float
    """revolutions integrated first and discarded (the transient), rev"""
    revs: float
    """revolutions measured after the transient (section points, spectrum or averaging span), rev"""


@dataclass(frozen=True)
class Renormalisation:
    """Lyapunov estimators: how the tangent vectors (or the separated twin) are renormalised and when
    the averaging stops; None: does not apply to the estimator."""

    interval_revs: float
    """renormalisation (re-orthonormalisation) interval, rev (periods)"""
    interval_no_period: float | None = None
    """the interval of a system without a period, in its time unit (None: interval_revs time
    units)"""
    align_revs: float | None = None
    """revolutions after the transient over which the tangent vectors settle onto the leading
    directions (discarded), rev"""
    tangent_err: bool | None = None
    """the tangent vectors take part in the step-size control (False: the state only, about half
    the CPU time)"""
    target_uncertainty: float | None = None
    """relative uncertainty of lambda1 to average for (e.g. 0.05); None: the fixed span"""
    max_total_factor: float | None = None
    """with target_uncertainty: the averaging stops at this multiple of the measured span"""
    n_blocks: int = 20
    """blocks of the blocking estimate of the uncertainty"""
    d0: float | None = None
    """initial separation of the two-trajectory (Benettin) estimator, scaled norm"""
    checks_per_period: int | None = None
    """Benettin: separation checks per interval of a periodic system (early renormalisation)"""
    max_growth: float | None = None
    """Benettin: renormalise early when the separation exceeds max_growth x d0"""


# --------------------------------------------------------------------------------------- instances

SIMULATE = Integration()
"""``nld.simulate`` / ``nld simulate`` (rtol: used when the scene recommends none)."""
SECTIONS = Integration(rtol=1e-8)
"""Poincaré sections (``stroboscopic``, ``hyperplane_section``) and bifurcation sweeps."""
SPECTRUM = Integration(rtol=1e-8, samples_per_rev=720)
"""``scene_spectrum`` / ``nld spectrum`` (720 samples per revolution: crank orders up to 360)."""
LYAPUNOV = Integration(rtol=1e-10)
"""Lyapunov exponents (both estimators), chaos maps, ``advance`` and ``stroboscopic_rhs``: a looser
tolerance can change a verdict (docs/analysis.md)."""

POINCARE_SPANS = Spans(transient_revs=100, revs=100)
"""``stroboscopic`` / ``nld poincare``."""
BIFURCATION_SPANS = Spans(transient_revs=100, revs=50)
"""``sweep`` / ``nld bifurcation`` (per swept value)."""
SPECTRUM_SPANS = Spans(transient_revs=10, revs=50)
"""``scene_spectrum`` / ``nld spectrum``."""
CHAOS_MAP_SPANS = Spans(transient_revs=20, revs=100)
"""``chaos_map`` / ``nld chaos-map`` (per cell)."""
TANGENT_SPANS = Spans(transient_revs=20.0, revs=200.0)
"""``lyapunov_tangent`` / ``nld lyapunov`` (both estimators on the command line)."""
BENETTIN_SPANS = Spans(transient_revs=20.0, revs=500.0)
"""``lyapunov_benettin`` called without spans."""

TANGENT = Renormalisation(interval_revs=1.0 / 8.0, interval_no_period=0.1, align_revs=2.0,
                          tangent_err=True, max_total_factor=10.0)
"""The tangent-dynamics estimator (``lyapunov_tangent``, ``nld lyapunov``)."""
BENETTIN = Renormalisation(interval_revs=1.0, d0=1e-4, checks_per_period=32, max_growth=10.0)
"""The two-trajectory estimator (``lyapunov_benettin``, ``nld lyapunov --estimator benettin``)."""


# ------------------------------------------------------------ the analyses' own defaults (dicts)
# The defaults of one analysis that the command line does not share: read by that analysis (and
# re-exported there as its ``DEFAULTS``), written here once (issue 39). docs/lyapunov.md and
# docs/attractors.md document them.

LYAPUNOV_DEFAULTS = {
    # "base" = the system's period (a scene: one crank revolution), or 1 time unit for a flow
    # without period.
    # Benettin, flows: renorm_interval = base, checks = 32 per interval when the system has a
    # period (else 1), early renormalisation when the separation exceeds max_growth * d0,
    # transient = 20 base, total = 500 base
    "flow": dict(rtol=LYAPUNOV.rtol, d0=BENETTIN.d0, max_growth=BENETTIN.max_growth,
                 checks_with_period=BENETTIN.checks_per_period,
                 transient_base=float(BENETTIN_SPANS.transient_revs),
                 total_base=float(BENETTIN_SPANS.revs), interval_base=BENETTIN.interval_revs),
    # perturbation vectors, flows: renorm_interval = base / 32 (period) or 0.1 (no period)
    "spectrum_flow": dict(rtol=LYAPUNOV.rtol, d0=1e-5, transient_base=20.0, total_base=500.0,
                          interval_period=1.0 / 32.0, interval_no_period=0.1),
    "map": dict(d0=1e-9, renorm_interval=1, transient=1000, total=100_000),
    # tangent dynamics, flows: renorm_interval = base / 8 (period) or 0.1 (no period),
    # transient 20 base (state only), align 2 base (vectors, discarded), total 200 base
    "tangent": dict(rtol=LYAPUNOV.rtol, transient_base=float(TANGENT_SPANS.transient_revs),
                    align_base=TANGENT.align_revs, total_base=float(TANGENT_SPANS.revs),
                    interval_period=TANGENT.interval_revs,
                    interval_no_period=TANGENT.interval_no_period),
    "n_blocks": TANGENT.n_blocks,
}
"""``nld.analysis.lyapunov`` (``lyapunov_benettin``, ``lyapunov_spectrum``, ``lyapunov_tangent``
called without spans): the settings besides the shared ones above (docs/lyapunov.md)."""

CENSUS_DEFAULTS = dict(starts=32, transient=50, record=100, max_period=16, period_tol=1e-4,
                       match_factor=3.0, lyapunov_members=2, rate_spread=0.5, escape=1e6, seed=0,
                       map_transient=1000, map_record=200)
"""``nld.analysis.attractors.census`` / ``nld attractors`` (docs/attractors.md; a scene's period is
one crank revolution): starts, transient and record in periods (a map: map_transient,
map_record iterations), max_period, the scaled period tolerance, the basin-matching factor, the
members whose lambda1 is computed, the rates' spread of a scene's sampler, the escape radius
(scaled), the sampler's seed."""

__all__ += ["LYAPUNOV_DEFAULTS", "CENSUS_DEFAULTS"]

def defaults_table() -> str:
    """The defaults above as Markdown (docs/analysis.md, "Default settings"): per class a table of
    its instances (what uses them, the value of every field; "-" where a field does not apply),
    then what each field means, with its unit."""
    field_docs, instance_docs = _docstrings()
    g = globals()
    out = []
    for cls in (Integration, Spans, Renormalisation):
        names = [n for n in __all__ if isinstance(g[n], cls)]
        cols = [f.name for f in fields(cls)]
        out.append(f"**{cls.__name__}** ({' '.join(cls.__doc__.split())})\n")
        out.append("| instance | used by | " + " | ".join(f"`{c}`" for c in cols) + " |")
        out.append("|---|---|" + "---|" * len(cols))
        for n in names:
            vals = [_fmt(getattr(g[n], c)) for c in cols]
            out.append(f"| `{n}` | {' '.join(instance_docs[n].split())} | " + " | ".join(vals) + " |")
        out.append("")
        for c in cols:
            out.append(f"- `{c}`: {' '.join(field_docs[cls.__name__][c].split())}")
        out.append("")
    return "\n".join(out)


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, (bool, str)):
        return str(v)
    if isinstance(v, float):
        return f"{v:g}"
    return f"{v:,}".replace(",", " ")


def _docstrings() -> tuple[dict, dict]:
    """({class: {field: docstring}}, {instance: docstring}) read from this module's source."""
    import ast
    from pathlib import Path

    def pairs(body):
        for a, b in zip(body, body[1:]):
            if isinstance(b, ast.Expr) and isinstance(b.value, ast.Constant) \
                    and isinstance(b.value.value, str):
                if isinstance(a, ast.AnnAssign):
                    yield a.target.id, b.value.value
                elif isinstance(a, ast.Assign) and len(a.targets) == 1:
                    yield a.targets[0].id, b.value.value

    tree = ast.parse(Path(__file__).read_text())
    classes = {node.name: dict(pairs(node.body)) for node in tree.body
               if isinstance(node, ast.ClassDef)}
    return classes, dict(pairs(tree.body))


# --------------------------------------------------------------------- chaos control of a scene
# (a block of its own: nld.analysis.scene_control and ``nld control``; issue 39 moved it here from
# nld/cli/control.py's DEFAULTS)


@dataclass(frozen=True)
class Control:
    """Chaos control of a crank-driven scene (``nld.analysis.scene_control.control_scene``, ``nld
    control``): defaults that work on the chaotic slider_crank_olyaei --set
    joints.B.clearance=2e-4 --set joints.B.friction.mu=0 (docs/control.md, "Control of a clearance
    mechanism": measured, not assumed)."""

    method: str = "edfc"
    """control method: pyragas, edfc (delayed feedback) or ogy"""
    gain: float = 1.0
    """delayed-feedback gain K, N m per unit of the signal (N m s/rad on an angular velocity)"""
    memory: float = 0.9
    """EDFC memory R in [0, 1) (pyragas: 0)"""
    target_period: int = 1
    """period of the target orbit, crank revolutions"""
    transient: int = 10
    """free revolutions before control, rev"""
    revs: int = 300
    """controlled revolutions, rev"""
    lyapunov_revs: int = 32
    """revolutions averaged by each closed-loop lambda1 (after a quarter as many, not counted), rev"""
    scan_transient: int = 20
    """revolutions under each gain of the stability domain before its lambda1, rev"""
    rtol: float = 1e-8
    """relative tolerance of the controlled and free integrations"""
    dp_max: float = 1.0
    """OGY: largest torque perturbation, N m"""
    radius: float = 1.0
    """OGY: scaled distance to the orbit within which it acts (state scales)"""
    lyapunov_interval: float = 0.25
    """renormalisation interval of the closed-loop lambda1, rev"""
    d0: float = 1e-5
    """separation of the two trajectories of the closed-loop lambda1 (scaled), far above the
    integration's noise"""
    chunk_revs: int = 5
    """revolutions per integration chunk of the controlled run (Ctrl-C, progress), rev"""
    samples_per_delay: int = 50
    """samples of the controlled run per delay (control_delayed's default)"""


CONTROL = Control()
"""``control_scene`` / ``nld control``."""

__all__ += ["Control", "CONTROL"]
