"""Attractor census: which motions coexist at one parameter point, how often each is reached, and
how they continue across a parameter.

Method (docs/attractors.md), after Attractors.jl (Datseris, Luiz & Wagemakers, "Effortless
estimation of basins of attraction", Chaos 32, 023104, 2022) with the classification of each run
done on its stroboscopic section:

1. **Starts.** N starting states, seeded: for a scene the assembled state with its positions moved
   by up to one state scale each (so each journal lands at a random point of its clearance circle;
   states whose journal would penetrate its bearing are redrawn), its rates moved by a normal
   sample of ``rate_spread`` state scales, and each contact memory (onset velocity, m/s) drawn
   uniformly in [0, its scale]; for any other system a ``sampler(rng)`` returning y (or (y, z)), or
   a box ``(lo, hi)``.
2. **Runs.** Each start is integrated for ``transient`` periods (a map: iterations), then its
   section is recorded for ``record`` periods (one integration, ``StroboscopicMap.orbit``).
3. **Each run's motion.** *escaping*: the state left every bound (non-finite, or ``escape``
   times the start's size); *failed*: the integration failed otherwise (counted, never classed);
   *periodic of period p*: the run lies on a stable period-p orbit found by Newton shooting
   (``nld.analysis.orbits.periodic_orbit``) from its last p points, where the run is
   near-periodic (the period test ``nld.analysis.poincare.section_period`` -- the one of ``nld
   poincare`` -- passes at NEAR_TOL of the scales over the last half of the record; a map: at
   tol = ``period_tol`` × the section's extent + 1e-10) or, later, unsettled (at the period of its
   closest returns); "lies on": its last max(2p, 8) points within NEAR_TOL of the orbit (an
   unsettled run: approaching it) and a whole number of contact onsets per period as the
   orbit's. The plain integration's section of a contact orbit jitters by its global error over a
   period (~1e5 rtol of the rate scales, docs/attractors.md "Period test and orbits"), so the
   orbit, not the tolerance of the points, decides. Without a converged stable orbit a run is
   periodic when the period test passes at tol = ``period_tol`` × the section's extent + 1e3
   rtol √N and its onsets are a whole number per period; *permanent contact*: a contact law
   with memory whose contact was closed at every point of the last half of the record with no
   onset there (a Newton orbit with the memory's neutral multiplier is such a motion, not a
   periodic attractor; the motion and its
   exponent depend on the memory recorded at the last onset: docs/contact-laws.md); else
   *not periodic*, decided below.
4. **Grouping.** Runs of the same class are one attractor when their section sets are close:
   periodic runs when they lie on one Newton orbit (the attractor *is* that orbit: its points,
   multipliers, λ1 = ln max|μ| / p, onsets per orbit); unpolished periodic runs when a cyclic
   shift brings every point within 10 tol; other sets when the
   median distance from each point of one set to the other set is at most ``match_factor`` times
   the larger median nearest-neighbour spacing within either set (plus 1e-3 of the census's
   extent). Permanent-contact runs are one class: the orbits of such a motion form a continuum
   selected by the history (each run settles on its own member, with its own period and λ1), so
   the class reports the range of its members' memory values and their λ1 spread, not one orbit.
5. **Exponents.** λ1 of each attractor from the tangent estimator (``lyapunov_tangent``) on up to
   ``lyapunov_members`` of its runs, continuing from the end of the section for ``record``
   periods; the attractor's λ1 is their mean and its uncertainty the largest run's uncertainty
   plus half their spread. A not-periodic attractor is *chaotic* when the verdict rule
   (``nld.analysis.verdict``) says chaotic, *quasi-periodic* when λ1 is zero within an
   uncertainty of at most ``QUASI_PERIODIC_UNC`` (0.05) per period, and otherwise *unsettled*
   (λ1 < 0: a motion still converging, or of a period above ``max_period``; or an exponent not
   resolved from zero over the recorded span): its runs are counted as unsettled, never forced
   into a class.
6. **Fractions.** Each attractor's basin fraction k/N with the Wilson 95 % score interval (Wilson
   1927; Brown, Cai & DasGupta 2001 for its coverage); unsettled and failed runs are fractions of
   their own.

Units: section points in the system's SI units (scene: m, rad, m/s, rad/s, and the memory in m/s);
λ1 per period (a scene: natural log per crank revolution), per iteration for a map.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from nld.analysis.poincare import section_period
from nld.errors import InputError, SolveError
from nld.settings import CENSUS_DEFAULTS
from nld.systems.derived import NumbaMap, PoincareMap

__all__ = ["Attractor", "CensusResult", "census", "census_sweep", "match_attractors",
           "wilson_interval", "section_period", "set_distance", "DEFAULTS", "KINDS",
           "scene_sampler"]

KINDS = ("periodic", "quasi-periodic", "chaotic", "permanent contact", "escaping")

# documented defaults (docs/attractors.md): nld.settings.CENSUS_DEFAULTS; a scene's "period" is
# one crank revolution
DEFAULTS = CENSUS_DEFAULTS
# a flow's run is *near-periodic* when its section repeats with period p to this scaled max-norm
# over the whole recorded span (the scales: clearance, clearance x crank speed ...); the orbit
# itself is then found by Newton shooting (``nld.analysis.orbits.periodic_orbit``) and the run is
# periodic when it lies within this distance of a stable orbit (docs/attractors.md, "Period test":
# a plain integration's section carries the integration's global error over each period,
# ~1e5 rtol of the rate scales on a contact orbit, far above rtol)
NEAR_TOL = 1e-3
# an unsettled run is tried by Newton only where its closest returns over the last half of the
# record are within this scaled max-norm (farther, Newton would start far from any orbit)
APPROACH_TOL = 0.1
# Newton iterations of a census polish (a near-periodic run starts within NEAR_TOL of its orbit;
# from farther it converges in a few more steps or not at all)
POLISH_ITER = 15
# two Newton orbits are one when a point of one is within max(ORBIT_MATCH, 10 x their tolerance)
# of a point of the other (scaled max-norm; as nld.analysis.orbits.find_orbits)
ORBIT_MATCH = 1e-6
# a not-periodic motion is quasi-periodic only when its λ1 is zero within an uncertainty of at
# most this (per period): a wide interval around zero is "not resolved", not quasi-periodic
QUASI_PERIODIC_UNC = 0.05
# the verdict check of a chaotic or quasi-periodic attractor: a tenth of the tolerance, twice the
# averaging span, from the same state
CHECK_RTOL, CHECK_SPAN = 0.1, 2.0


# ---------------------------------------------------------------- statistics
def wilson_interval(k: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion k/n (default 95 %; Wilson 1927)."""
    if n <= 0:
        return (0.0, 1.0)
    p = k / n
    den = 1.0 + z * z / n
    c = (p + z * z / (2 * n)) / den
    h = z / den * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return (max(0.0, c - h), min(1.0, c + h))


# ---------------------------------------------------------------- section geometry
def _diff(a, b, angles) -> np.ndarray:
    """a - b (broadcast) with angle components brought into [-pi, pi)."""
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    if angles.size:
        d[..., angles] -= 2.0 * math.pi * np.floor((d[..., angles] + math.pi) / (2.0 * math.pi))
    return d


def _pairwise(A, B, scales, angles) -> np.ndarray:
    """Scaled distances between every point of A (m, N) and of B (k, N): (m, k)."""
    d = _diff(A[:, None, :], B[None, :, :], angles) / scales
    return np.sqrt(np.sum(d * d, axis=-1))


def _extent(X, scales) -> float:
    """The scaled diameter of a point set's bounding box."""
    if X.shape[0] == 0:
        return 0.0
    r = (np.max(X, axis=0) - np.min(X, axis=0)) / scales
    return float(np.sqrt(np.sum(r * r)))


def _nn_spacing(A, scales, angles) -> float:
    """The median nearest-neighbour distance within A (0 for fewer than 2 distinct points)."""
    if A.shape[0] < 2:
        return 0.0
    D = _pairwise(A, A, scales, angles)
    np.fill_diagonal(D, np.inf)
    return float(np.median(np.min(D, axis=1)))


def set_distance(A, B, scales, angles=None) -> float:
    """max of the median distances from each point of one set to the other set (scaled norm)."""
    angles = np.zeros(0, dtype=np.int64) if angles is None else np.asarray(angles, dtype=np.int64)
    D = _pairwise(A, B, scales, angles)
    return float(max(np.median(np.min(D, axis=1)), np.median(np.min(D, axis=0))))


def _orbit_distance(A, B, scales, angles) -> float:
    """Two period-p point sets: the least over cyclic shifts of the largest point distance."""
    p = A.shape[0]
    best = math.inf
    for s in range(p):
        d = _diff(A, np.roll(B, -s, axis=0), angles) / scales
        best = min(best, float(np.max(np.sqrt(np.sum(d * d, axis=1)))))
    return best


# ---------------------------------------------------------------- results
@dataclass
class Attractor:
    """One attractor of a census.

    kind: "periodic", "quasi-periodic", "chaotic", "permanent contact" or "escaping".
    period: the section period p of a periodic (or periodic permanent-contact) motion, else 0.
    count / fraction / fraction_interval: runs that reached it, k/N and the Wilson 95 % interval.
    points: representative section points (a periodic attractor: the p points of its orbit
    from Newton shooting; else the first run's last <= 64 points; SI units).
    lambda1, lambda1_uncertainty: per period (scene: per crank revolution; map: per iteration);
    of a periodic attractor ln max|μ| / p from the orbit's Floquet multipliers (its uncertainty
    from the multipliers' ``multiplier_error``), else the tangent estimate on its runs;
    lambda1_runs: (run, λ1, uncertainty) of the runs measured by the tangent estimator, whose
    mean is ``lambda1_tangent`` ± ``lambda1_tangent_uncertainty`` (a periodic attractor: the
    second method's check of ln max|μ| / p).
    onsets_per_period: contact onsets per period (all clearance joints), mean over its runs; of a
    periodic attractor the orbit's whole number ``onsets_per_orbit`` (per p periods) / p.
    multipliers, multiplier_error, orbit_residual, orbit: a periodic attractor's orbit
    (``nld.analysis.orbits.PeriodicOrbit``, the orbit ``nld orbits`` finds), its Floquet
    multipliers (by decreasing modulus), the uncertainty of max|μ| and the Newton residual.
    conditional_on_memory: permanent contact: the memory entries' values (m/s) over its runs
    (min, max per entry), on which the motion and λ1 depend.
    runs: indices of the starts that reached it.
    """
    id: int
    kind: str
    period: int
    count: int
    fraction: float
    fraction_interval: tuple
    points: np.ndarray
    lambda1: float = math.nan
    lambda1_uncertainty: float = math.nan
    lambda1_runs: list = field(default_factory=list)
    onsets_per_period: float = math.nan
    conditional_on_memory: dict | None = None
    runs: list = field(default_factory=list)
    note: str = ""
    verdict: str = ""
    lambda1_check: float = math.nan
    lambda1_check_uncertainty: float = math.nan
    onsets_per_orbit: int | None = None
    multipliers: np.ndarray | None = None
    multiplier_error: float = math.nan
    orbit_residual: float = math.nan
    orbit: object = field(default=None, repr=False)
    lambda1_tangent: float = math.nan
    lambda1_tangent_uncertainty: float = math.nan

    def line(self, period_name: str = "period") -> str:
        lo, hi = self.fraction_interval
        kind = self.kind + (f" (period {self.period})" if self.period else "")
        lam = ("λ1 not measured" if not math.isfinite(self.lambda1) else
               f"λ1 = {self.lambda1:.4g} ± {self.lambda1_uncertainty:.2g} per {period_name}")
        s = (f"#{self.id} {kind}: fraction {self.fraction:.3f} [{lo:.3f}, {hi:.3f}] "
             f"({self.count} runs), {lam}")
        if math.isfinite(self.lambda1_check):
            s += (f" (check at a tenth of the tolerance over twice the span: "
                  f"{self.lambda1_check:.4g} ± {self.lambda1_check_uncertainty:.2g}; verdict "
                  f"{self.verdict})")
        if self.multipliers is not None and len(self.multipliers):
            s += (f", orbit by Newton shooting (residual {self.orbit_residual:.2g}): max |μ| = "
                  f"{float(np.max(np.abs(self.multipliers))):.4g} ± {self.multiplier_error:.2g}, "
                  f"λ1 = ln max|μ| / {self.period}")
            if math.isfinite(self.lambda1_tangent):
                s += (f" (tangent estimate {self.lambda1_tangent:.4g} ± "
                      f"{self.lambda1_tangent_uncertainty:.2g})")
        if self.onsets_per_orbit is not None:
            s += f", {self.onsets_per_orbit} contact onsets per period-{self.period} orbit"
        elif math.isfinite(self.onsets_per_period):
            s += f", {self.onsets_per_period:.3g} contact onsets per {period_name}"
        if self.note and self.kind == "periodic":
            s += f" ({self.note})"
        if self.conditional_on_memory:
            mem = ", ".join(f"{k} in [{a:.3g}, {b:.3g}] m/s"
                            for k, (a, b) in self.conditional_on_memory.items())
            s += f"; conditional on the recorded memory ({mem})"
        return s

    def to_dict(self) -> dict:
        return {"id": self.id, "kind": self.kind, "period": self.period, "count": self.count,
                "fraction": self.fraction, "fraction_interval": list(self.fraction_interval),
                "lambda1_per_revolution": _num(self.lambda1),
                "lambda1_uncertainty": _num(self.lambda1_uncertainty),
                "onsets_per_period": _num(self.onsets_per_period),
                "conditional_on_memory": self.conditional_on_memory, "runs": list(self.runs),
                "note": self.note, "verdict": self.verdict,
                "lambda1_check": _num(self.lambda1_check),
                "lambda1_check_uncertainty": _num(self.lambda1_check_uncertainty),
                "onsets_per_orbit": self.onsets_per_orbit,
                "multipliers": (None if self.multipliers is None else
                                [[float(m.real), float(m.imag)] for m in self.multipliers]),
                "multiplier_error": _num(self.multiplier_error),
                "orbit_residual": _num(self.orbit_residual),
                "orbit_points": (None if self.orbit is None else
                                 np.asarray(self.points, dtype=float).tolist()),
                "lambda1_tangent": _num(self.lambda1_tangent),
                "lambda1_tangent_uncertainty": _num(self.lambda1_tangent_uncertainty)}


def _num(v):
    return None if v is None or not math.isfinite(v) else float(v)


@dataclass
class CensusResult:
    """The attractors found from N starts, and what happened to the other runs.

    attractors: list of :class:`Attractor`, largest fraction first. unsettled: runs whose motion
    did not settle on a class within the run (not periodic and λ1 < 0, or too short), failed:
    integrations that failed without escaping; each with its fraction and Wilson interval.
    runs: per start (a pandas DataFrame): the class found, its period, onsets per period, the
    attractor id (-1 unsettled, -2 failed) and a message. settings: every setting used.
    """
    system: str
    attractors: list
    n_starts: int
    unsettled: int
    failed: int
    runs: object
    settings: dict
    period_name: str = "period"
    state_names: list = field(default_factory=list)
    scales: np.ndarray = field(default_factory=lambda: np.zeros(0))
    angles: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def verdict(self) -> str:
        """The verdict rule's word for this parameter point (``nld.analysis.verdict``)."""
        from nld.analysis.verdict import COEXISTING, census_verdict
        if len(self.attractors) == 1 and self.attractors[0].verdict:
            return self.attractors[0].verdict          # the checked word of the one motion
        return COEXISTING if len(self.attractors) > 1 else census_verdict([])

    @property
    def unsettled_interval(self):
        return wilson_interval(self.unsettled, self.n_starts)

    def __str__(self) -> str:
        lines = [f"census of {self.system}: {len(self.attractors)} attractor(s) from "
                 f"{self.n_starts} starts ({self.verdict})"]
        lines += ["  " + a.line(self.period_name) for a in self.attractors]
        if self.unsettled:
            lo, hi = self.unsettled_interval
            lines.append(f"  unsettled: {self.unsettled} runs, fraction "
                         f"{self.unsettled / self.n_starts:.3f} [{lo:.3f}, {hi:.3f}]")
        if self.failed:
            lines.append(f"  failed: {self.failed} runs")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"attractors": [a.to_dict() for a in self.attractors],
                "unsettled": self.unsettled, "failed": self.failed, "n_starts": self.n_starts,
                "verdict": self.verdict, "settings": self.settings}


# ---------------------------------------------------------------- starts
def scene_sampler(system, rate_spread: float = DEFAULTS["rate_spread"]):
    """The default start sampler of a scene system: ``sampler(rng) -> (y, z)`` (module
    docstring, step 1)."""
    from nld.systems.derived import contact_events
    n = system.n // 2
    contacts = contact_events(system)
    mem = np.asarray(system.memory, dtype=np.int64)
    vmem = float(np.max(system.scales[n:])) if n else 1.0
    y0, z0 = system.y0.copy(), system.z0.copy()

    def sample(rng):
        g = np.zeros(max(1, int(system.n_events)))
        for shrink in (1.0, 0.5, 0.25, 0.125, 0.0):
            for _ in range(50):
                y = y0.copy()
                y[:n] += shrink * system.scales[:n] * rng.uniform(-1.0, 1.0, n)
                y[n:] += rate_spread * system.scales[n:] * rng.standard_normal(system.n - n)
                z = z0.copy()
                if system.init_modes is not None:
                    system.init_modes(system.t0, y, system.p, z)
                if contacts.size:
                    system.events(system.t0, y, system.p, z, g)
                    if np.any(g[contacts] > 0.0) and shrink > 0.0:
                        continue          # a journal inside its bearing's wall: draw again
                if mem.size:
                    z[mem] = rng.uniform(0.0, vmem, mem.size)
                return y, z
        return y0.copy(), z0.copy()
    return sample


def _box_sampler(lo, hi, z0):
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)

    def sample(rng):
        return lo + (hi - lo) * rng.uniform(0.0, 1.0, lo.size), z0.copy()
    return sample


def _flow_of(system):
    """The system whose states the starts are: a Poincaré map's flow, else the system."""
    return system.flow if isinstance(system, PoincareMap) else system


def _as_sampler(system, sampler, rate_spread):
    base = _flow_of(system)
    z0 = np.asarray(base.z0, dtype=float)
    if sampler is None:
        if base.is_scene:
            return scene_sampler(base, rate_spread)
        raise InputError(f"sampler = None: {system.name} is not a scene; give sampler(rng) -> y "
                         f"(or (y, z)) or a box (lo, hi) of starting states")
    if isinstance(sampler, tuple) and len(sampler) == 2 and not callable(sampler[0]):
        lo, hi = (np.asarray(v, dtype=float).ravel() for v in sampler)
        if (lo.size != base.n or hi.size != base.n or not np.all(hi >= lo)
                or not np.all(np.isfinite(lo)) or not np.all(np.isfinite(hi))):
            raise InputError(f"sampler = (lo, hi): need two vectors of {base.n} values, finite, "
                             f"with hi >= lo")
        return _box_sampler(lo, hi, z0)
    if not callable(sampler):
        raise InputError(f"sampler = {sampler!r}: must be sampler(rng) -> y or (y, z), or a box "
                         f"(lo, hi)")

    def sample(rng):
        out = sampler(rng)
        if isinstance(out, tuple):
            if len(out) != 2:
                raise InputError(f"sampler returned a tuple of {len(out)}: must return y or "
                                 f"(y, z)")
            y, z = out
        else:
            y, z = out, z0.copy()
        try:
            y = np.asarray(y, dtype=float).ravel()
            z = np.asarray(z, dtype=float).ravel()
        except (TypeError, ValueError):
            raise InputError(f"sampler returned {out!r}: must return y or (y, z), arrays of "
                             f"numbers") from None
        if y.size != base.n:
            raise InputError(f"sampler returned {y.size} values: the system has {base.n} "
                             f"states")
        if z.size != z0.size:
            raise InputError(f"sampler returned a discrete state z of {z.size} values: the "
                             f"system's has {z0.size} (its z0)")
        if not (np.all(np.isfinite(y)) and np.all(np.isfinite(z))):
            raise InputError(f"sampler returned a non-finite state (y = {y.tolist()!r}): every "
                             f"starting state must be finite")
        return y, z
    return sample


# ---------------------------------------------------------------- one run
@dataclass
class _Run:
    status: str                # "ok", "escaping", "failed"
    X: np.ndarray              # recorded section points (m, N)
    z: np.ndarray              # discrete state after the last point
    onsets: float              # onsets per period over the recorded span
    permanent: bool
    memory: dict
    period: int                # the period test's period (tolerance ``tol``)
    tol: float
    message: str = ""
    near: int = 0              # near-periodic period (NEAR_TOL; flows), else = period
    Zp: list = field(default_factory=list)     # discrete states at the last points (<= 2 P)
    ret_time: float = math.nan  # mean time per section step (s)
    orbit: int = -1            # index of the census orbit the run lies on (-1: none)
    step_onsets: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))


def _record_map(system, y, transient, record, escape):
    """Iterate a (numba) map: the transient, then `record` points. (X, status, message)."""
    from nld.systems.core import iterate
    size = max(1.0, float(np.max(np.abs(y))))
    x = np.asarray(y, dtype=float).copy()
    step = 50
    done = 0
    while done < transient:
        m = min(step, transient - done)
        x = iterate(system, x, m)
        done += m
        if not np.all(np.isfinite(x)) or np.max(np.abs(x)) > escape * size:
            return np.zeros((0, system.n)), "escaping", f"|x| left {escape:g} x the start's size"
    X = np.empty((record, system.n))
    for i in range(record):
        x = iterate(system, x, 1)
        if not np.all(np.isfinite(x)) or np.max(np.abs(x)) > escape * size:
            return X[:i], "escaping", f"|x| left {escape:g} x the start's size"
        X[i] = x
    return X, "ok", ""


def _record_poincare(pmap, y, z, transient, record):
    """Iterate a Poincaré map: the transient, then ``record`` crossings. (X, Z, onsets per
    contact event over the recorded steps, mean return time, status, message)."""
    x = pmap.pack(y, z)
    zz = np.array(z, dtype=float)
    X, Z, times, per_step = [], [], [], []
    onsets = np.zeros(pmap.contacts.size, dtype=np.int64)
    try:
        for k in range(transient + record):
            st = pmap.step(x, zz, relabel=(k == 0))
            x, zz = st.x, st.z
            if k >= transient:
                X.append(x)
                Z.append(zz)
                times.append(st.time)
                if st.onsets.size:
                    onsets += st.onsets
                    per_step.append(np.asarray(st.onsets, dtype=np.int64))
    except SolveError as e:
        return (np.array(X).reshape(len(X), pmap.n), Z, onsets,
                float(np.mean(times)) if times else math.nan, "failed", str(e),
                np.array(per_step, dtype=np.int64).reshape(len(per_step), pmap.contacts.size))
    return (np.array(X), Z, onsets, float(np.mean(times)), "ok", "",
            np.array(per_step, dtype=np.int64).reshape(len(per_step), pmap.contacts.size))


def _one_run(ctx, y, z) -> _Run:
    """Transient and section of one start (never raises for a failed integration)."""
    system, smap = ctx["system"], ctx["map"]
    Zs: list = []
    ret = math.nan
    step_onsets = np.zeros((0, 0), dtype=np.int64)
    w = max(16, ctx["record"] // 2)         # the settled window: the last half of the record
    if ctx["kind"] == "map":
        X, status, msg = _record_map(system, y, ctx["transient"], ctx["record"], ctx["escape"])
        zz = np.zeros(0)
        onsets, permanent, memory = math.nan, False, {}
        ret = 1.0
    elif ctx["kind"] == "poincare":
        X, Zs, ons, ret, status, msg, step_onsets = _record_poincare(
            smap, y, z, ctx["transient"], ctx["record"])
        zz = np.array(Zs[-1]) if Zs else np.array(z, dtype=float)
        if status != "ok":
            last = X[-1] if X.shape[0] else y
            if not np.all(np.isfinite(np.asarray(last, dtype=float))):
                status = "escaping"
        n_rec = max(1, X.shape[0])
        onsets = float(np.sum(ons)) / n_rec if ons.size else math.nan
        if step_onsets.shape[0] == X.shape[0] and X.shape[0] and step_onsets.size:
            onsets = float(np.mean(np.sum(step_onsets[-w:], axis=1)))
        permanent, memory = False, {}
    else:
        x = smap.pack(y, z)
        sr = smap.orbit(x, z, ctx["record"], transient=ctx["transient"])
        X, zz = sr.X, sr.z
        Zs = list(sr.Z) if sr.Z is not None else []
        step_onsets = np.asarray(sr.step_onsets, dtype=np.int64)
        ret = smap.T
        status, msg = ("ok", "") if sr.success else ("failed", sr.message)
        if not sr.success:
            last = X[-1] if X.shape[0] else sr.y_start
            size = float(np.max(np.abs(y / smap.scales[:y.size]))) + 1.0
            big = float(np.max(np.abs(np.asarray(last)[:y.size] / smap.scales[:y.size])))
            if not math.isfinite(big) or big > ctx["escape"] * size:
                status = "escaping"
        n_rec = max(1, X.shape[0])
        onsets = float(np.sum(sr.onsets)) / n_rec if sr.onsets.size else math.nan
        known = step_onsets.shape[0] == X.shape[0] and X.shape[0] > 0 and step_onsets.size > 0
        if known:       # onsets per period over the settled window (not the record's start)
            onsets = float(np.mean(np.sum(step_onsets[-w:], axis=1)))
        permanent, memory = False, {}
        if smap.memory.size and X.shape[0]:
            # permanent contact: closed at every point of the settled window, with no onset
            # in it (a run that had onsets early in the record and then stayed in contact is
            # on a member of the continuum, not on an impacting orbit)
            names = smap.state_names[smap.n_y:]
            for j, e in enumerate(smap.memory_events):
                if e < 0:
                    continue
                jc = int(np.nonzero(smap.contacts == e)[0][0])
                none = (int(np.sum(step_onsets[-w:, jc])) == 0 if known
                        else sr.onsets[jc] == 0)
                if none and np.all(sr.gaps[-w:, jc] > 0.0):
                    permanent = True
                    memory[names[j]] = float(X[-1, smap.n_y + j])
    scales, angles = ctx["scales"], ctx["angles"]
    tol = ctx["period_tol"] * _extent(X, scales) + ctx["tol_floor"]
    period = near = 0
    if status == "ok":
        # the period test over the last half of the record (the first half: the run settling)
        w = max(16, X.shape[0] // 2)
        period = section_period(X, scales, tol=tol, max_period=ctx["max_period"], angles=angles,
                                window=w)
        near = period if ctx["kind"] == "map" else section_period(
            X, scales, tol=max(tol, NEAR_TOL), max_period=ctx["max_period"], angles=angles,
            window=w)
    keep = 2 * ctx["max_period"]
    step_onsets = (np.sum(step_onsets, axis=1) if step_onsets.ndim == 2 and
                   step_onsets.shape[0] == X.shape[0] and step_onsets.shape[1]
                   else np.zeros(0, dtype=np.int64))      # empty: unknown (an overflowed log)
    return _Run(status, X, zz, onsets, permanent, memory, period, tol, msg, near=near,
                Zp=[np.array(q) for q in Zs[-keep:]], ret_time=ret, step_onsets=step_onsets)


def _run_start(ctx, i, y, z):
    try:
        return _one_run(ctx, y, z)
    except SolveError as e:
        return _Run("failed", np.zeros((0, ctx["n"])), np.zeros(0), math.nan, False, {}, 0, 0.0,
                    str(e))


# ---------------------------------------------------------------- exponents
def _exponent(ctx, run: _Run, seed: int, rtol_factor: float = 1.0, span_factor: float = 1.0):
    """(λ1, uncertainty) per period from the end of the run's section, or (nan, nan, message);
    rtol_factor / span_factor: the verdict check's tighter tolerance and longer span."""
    from nld.analysis.lyapunov import lyapunov_tangent
    system, smap = ctx["system"], ctx["map"]
    if ctx["kind"] == "map":
        s = copy.copy(system)
        s.y0 = np.array(run.X[-1], dtype=float)
        res = lyapunov_tangent(s, transient=0, total=int(ctx["record_lyap"] * span_factor),
                               seed=seed, progress=False)
        return float(res.exponent), float(np.ravel(res.uncertainty)[0]), ""
    flow = _flow_of(system)
    s = copy.copy(flow)
    zlast = run.Zp[-1] if run.Zp else run.z
    y, zz = smap.unpack(run.X[-1], zlast)
    s.y0, s.z0 = y, zz
    span = ctx["record_lyap"] * span_factor * run.ret_time
    try:
        res = lyapunov_tangent(s, transient=0.0, total=span,
                               rtol=max(1e-14, ctx["rtol"] * rtol_factor), seed=seed,
                               progress=False)
    except (SolveError, InputError) as e:
        return math.nan, math.nan, str(e)
    if ctx["kind"] == "poincare":       # per second x the mean return time: per return
        return (float(res.exponent) * run.ret_time,
                float(np.ravel(res.uncertainty)[0]) * run.ret_time, "")
    return float(res.per_revolution), float(res.uncertainty_per_revolution), ""


# ---------------------------------------------------------------- orbits (Newton shooting)
def _orbit_tol(orb) -> float:
    return max(ORBIT_MATCH, 10.0 * float(orb.tolerance))


def _distance_to_orbit(ctx, X, orb) -> np.ndarray:
    """Scaled max-norm distance of each point of X to the nearest point of the orbit."""
    m = orb.map
    sc = m.scales
    D = np.array([[float(np.max(np.abs(m.difference(x, q) / sc))) for q in orb.points]
                  for x in X])
    return np.min(D, axis=1) if D.size else np.zeros(0)


def _polish(ctx, run: _Run, p: int):
    """The period-p orbit by Newton shooting (``nld.analysis.orbits.periodic_orbit``) from the
    run's last p points; None where Newton does not converge, the orbit is not of prime period
    p, or it is unstable (module docstring, step 3)."""
    from nld.analysis.orbits import periodic_orbit, prime_period
    m = ctx["orbit_map"]
    if run.X.shape[0] < p:
        return None
    guess = run.X[-p:]
    z = run.Zp[-p] if len(run.Zp) >= p else None
    try:
        orb = periodic_orbit(m, p, guess if p > 1 else guess[0], z=z,
                             check=ctx["kind"] != "map", max_iter=POLISH_ITER)
    except (SolveError, InputError, FloatingPointError, np.linalg.LinAlgError, ValueError):
        return None
    if not orb.converged or not np.all(np.isfinite(orb.points)):
        return None
    if prime_period(m, orb.points, _orbit_tol(orb)) != p:
        return None
    if orb.memory_neutral:
        return None         # a member of a permanent-contact continuum: that class, not this
    if orb.stability != "stable":
        return None
    return orb


def _lies_on(ctx, run: _Run, orb, approach: bool = False) -> bool:
    """The run is on the orbit: every recorded point of its last max(2p, 8) within NEAR_TOL
    (flows; a map: 10 x its period tolerance) of an orbit point, and its contact onsets a whole
    number per period as the orbit's. ``approach``: it is enough that the run's distance to the
    orbit fell by half over the recorded span and it ends within 10 NEAR_TOL (a run still
    converging: a stable orbit with a multiplier near 1)."""
    p = orb.period
    if run.X.shape[0] < 2 * p:
        return False
    near = NEAR_TOL if ctx["kind"] != "map" else max(10.0 * run.tol, _orbit_tol(orb))
    d = _distance_to_orbit(ctx, run.X[-max(2 * p, 8):], orb)
    ok = bool(np.all(d <= near))
    if not ok and approach:
        q = max(2, run.X.shape[0] // 4)
        d0 = _distance_to_orbit(ctx, run.X[:q], orb)
        ok = bool(np.max(d) <= 10.0 * near and np.mean(d[-q:] if d.size >= q else d)
                  <= 0.5 * np.mean(d0))
    if ok and ctx["kind"] != "map" and orb.onsets.size:
        # the run's contact onsets in each of its last periods: the orbit's whole number
        blocks = _onset_blocks(run, p, max(2 * p, 8))
        ok = blocks is None or bool(np.all(blocks == int(orb.onsets_per_period)))
    return ok


def _onset_blocks(run: _Run, p: int, span: int):
    """The run's contact onsets in each of its last floor(span / p) whole periods of p steps
    (None where the per-step counts are not known)."""
    s = run.step_onsets
    if s.size == 0 or s.size < p:
        return None
    k = max(1, min(span, s.size) // p)
    return s[s.size - k * p:].reshape(k, p).sum(axis=1)


def _same_orbit(a, b) -> bool:
    """Two orbits of one period are one when a point of one is a point of the other (any cyclic
    shift), to max(ORBIT_MATCH, 10 x their Newton tolerance) in the scaled max-norm."""
    if a.period != b.period:
        return False
    m, tol = a.map, max(_orbit_tol(a), _orbit_tol(b))
    return any(float(np.max(np.abs(m.difference(a.points[0], q) / m.scales))) <= tol
               for q in b.points)


def _assign_orbit(ctx, orbits: list, run: _Run, p: int, approach: bool = False) -> int:
    """The index in ``orbits`` of the census orbit that the run lies on (found before, or by
    Newton from the run and appended); -1 for none."""
    for k, orb in enumerate(orbits):
        if orb.period == p and _lies_on(ctx, run, orb, approach):
            return k
    orb = _polish(ctx, run, p)
    if orb is None or not _lies_on(ctx, run, orb, approach):
        return -1
    for k, o in enumerate(orbits):
        if _same_orbit(o, orb):
            return k
    orbits.append(orb)
    return len(orbits) - 1


def _best_period(ctx, run: _Run) -> int:
    """The p <= max_period whose returns ||x_{k+p} - x_k|| over the last half of the record are
    smallest (the smallest p within a factor 2 of the least): the period Newton is tried at for
    a run that converges (λ1 < 0) without passing the period test; 0 where even the closest
    returns are farther apart than APPROACH_TOL (scaled)."""
    X = run.X
    n = X.shape[0]
    best = []
    for p in range(1, ctx["max_period"] + 1):
        w = n // 2
        if w < 2 * p:
            break
        d = _diff(X[n - w + p:], X[n - w:n - p], ctx["angles"]) / ctx["scales"]
        best.append(float(np.max(np.abs(d))))
    if not best:
        return 0
    lo = min(best)
    if lo > APPROACH_TOL:
        return 0            # no return close enough for Newton to start from
    return next(p + 1 for p, v in enumerate(best) if v <= 2.0 * lo)


# ---------------------------------------------------------------- grouping
def _same(ctx, a: _Run, b: _Run, extent: float) -> bool:
    scales, angles = ctx["scales"], ctx["angles"]
    if a.period and b.period:
        if a.period != b.period:
            return False
        A, B = a.X[-a.period:], b.X[-b.period:]
        return _orbit_distance(A, B, scales, angles) <= 10.0 * max(a.tol, b.tol)
    A, B = a.X[-64:], b.X[-64:]
    d = set_distance(A, B, scales, angles)
    lim = ctx["match_factor"] * max(_nn_spacing(A, scales, angles),
                                    _nn_spacing(B, scales, angles)) + 1e-3 * extent
    return d <= lim


def _group(ctx, runs: list, skip=()) -> list[list[int]]:
    """Runs (settled ones, not in ``skip``) grouped: periodic by period and orbit, permanent
    contact, others."""
    ok = [i for i, r in enumerate(runs) if r.status == "ok" and r.X.shape[0] and i not in skip]
    extent = _extent(np.concatenate([runs[i].X[-64:] for i in ok]), ctx["scales"]) if ok else 0.0
    groups: list[list[int]] = []
    for i in ok:
        r = runs[i]
        for g in groups:
            h = runs[g[0]]
            if h.permanent and r.permanent:          # one continuum: module docstring, step 4
                g.append(i)
                break
            if (h.permanent == r.permanent and bool(h.period) == bool(r.period)
                    and _same(ctx, h, r, extent)):
                g.append(i)
                break
        else:
            groups.append([i])
    return groups


# ---------------------------------------------------------------- where the runs run
_WORKER_CTX: dict = {}


def _payload(system, ctx, workers, dask=None):
    """What a worker process needs to rebuild the system and the census settings: a scene's
    Scene and integrator (other systems hold numba functions that do not travel: None)."""
    if not system.is_scene or (workers == 1 and dask is None):
        return None
    keys = ("rtol", "transient", "record", "max_period", "period_tol", "match_factor", "escape")
    return dict(scene=system.scene, method=system.method, event_samples=system.event_samples,
                settings={k: ctx[k] for k in keys})


def _ctx_of(payload, ctx):
    """The census context in this process (a worker builds it once from the payload)."""
    if ctx is not None:
        return ctx
    import hashlib
    import pickle
    key = hashlib.sha1(pickle.dumps(payload)).hexdigest()
    got = _WORKER_CTX.get(key)
    if got is None:
        from nld.systems.core import SceneSystem
        sysm = SceneSystem(payload["scene"], method=payload["method"],
                           event_samples=payload["event_samples"])
        st = payload["settings"]
        got = _context(sysm, st["rtol"], st["transient"], st["record"], st["max_period"],
                       st["period_tol"], st["match_factor"], st["escape"])
        _WORKER_CTX.clear()
        _WORKER_CTX[key] = got
    return got


def _census_start(payload, i, y, z, ctx=None) -> dict:
    return dict(direction="census", index=int(i), run=_run_start(_ctx_of(payload, ctx), i, y, z))


def _census_exponent(payload, m, run, seed, ctx=None) -> dict:
    return {"direction": "exponent", "index": int(m),
            "lambda": _exponent(_ctx_of(payload, ctx), run, seed)}


def _execute(fn, payload, ctx, items, workers, dask=None):
    """Records of fn over items: in this process (ctx), or on the pool / Dask (payload)."""
    if payload is None:
        for item in items:
            yield fn(None, *item, ctx=ctx)
        return
    from contextlib import closing
    from nld.sweeps.executors import execute
    with closing(execute(fn, payload, items, workers=workers, dask=dask)) as it:
        yield from it


# ---------------------------------------------------------------- the census
def _context(system, rtol, transient, record, max_period, period_tol, match_factor, escape):
    from nld.settings import LYAPUNOV
    from nld.systems.derived import StroboscopicMap
    ctx = dict(system=system, max_period=int(max_period), period_tol=float(period_tol),
               match_factor=float(match_factor), escape=float(escape), n=system.n)
    if isinstance(system, PoincareMap):
        if rtol is not None and float(rtol) != system.rtol:
            raise InputError(f"rtol = {rtol!r}: a PoincareMap carries its own tolerance "
                             f"(rtol = {system.rtol:g}); build it with PoincareMap(..., rtol=...)")
        ctx.update(kind="poincare", map=system, orbit_map=system, rtol=system.rtol,
                   tol_floor=1e3 * system.rtol * math.sqrt(system.n), scales=system.scales,
                   angles=np.asarray(system.angle_states, dtype=np.int64),
                   transient=int(DEFAULTS["transient"] if transient is None else transient),
                   record=int(DEFAULTS["record"] if record is None else record))
        ctx["record_lyap"] = ctx["record"]
        return ctx
    if system.is_map:
        if system.is_derived:
            raise InputError(f"{system.name}: give the forced flow itself (the census samples its "
                             f"stroboscopic section), or a PoincareMap of an autonomous flow")
        ctx.update(kind="map", map=None, orbit_map=NumbaMap(system), rtol=None, tol_floor=1e-10,
                   scales=np.ones(system.n), angles=np.zeros(0, dtype=np.int64),
                   transient=int(DEFAULTS["map_transient"] if transient is None else transient),
                   record=int(DEFAULTS["map_record"] if record is None else record))
        ctx["record_lyap"] = max(1000, 10 * ctx["record"])
        return ctx
    if system.period is None:
        raise InputError(f"{system.name} is an autonomous flow (no forcing period): give "
                         f"section=(normal, offset) or section=(normal, offset, direction), or "
                         f"a PoincareMap(system, normal, offset), and the census samples that "
                         f"Poincaré section")
    rtol = LYAPUNOV.rtol if rtol is None else float(rtol)
    smap = StroboscopicMap(system, rtol=rtol)
    ctx.update(kind="stroboscopic", map=smap, orbit_map=smap, rtol=rtol,
               tol_floor=1e3 * rtol * math.sqrt(smap.n),
               scales=smap.scales, angles=np.asarray(smap.angle_states, dtype=np.int64),
               transient=int(DEFAULTS["transient"] if transient is None else transient),
               record=int(DEFAULTS["record"] if record is None else record))
    ctx["record_lyap"] = ctx["record"]
    ctx["n"] = smap.n
    return ctx


def _check_int(name, v, lo):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
        raise InputError(f"{name} = {v!r}: must be a whole number >= {lo}")
    return int(v)


def _whole_onsets(run: _Run) -> bool:
    """A period-p run (no orbit from Newton) has the same whole number of contact onsets in each
    period of the last half of its record (where the period test looked); without per-step
    counts: its count over the recorded span is a whole number x the periods, give or take one
    period's."""
    if not math.isfinite(run.onsets) or not run.period:
        return True
    blocks = _onset_blocks(run, run.period, max(16, run.X.shape[0] // 2))
    if blocks is not None:
        return bool(np.all(blocks == blocks[0]))
    n_rec = run.X.shape[0]
    total = run.onsets * n_rec
    k = round(total * run.period / n_rec)
    return abs(total - k * n_rec / run.period) <= k + 1e-9 and (
        k > 0 or total == 0)


def _orbit_lambda(orb):
    """(λ1, uncertainty) per period of an orbit: ln max|μ| / p (a continuum's neutral memory
    multiplier left out) and its uncertainty from the multipliers' error; and that error of
    max|μ|."""
    amu = np.abs(np.asarray(orb.multipliers))
    if amu.size == 0:
        return math.nan, math.nan, math.nan
    consider = amu
    if orb.memory_neutral and amu.size > 1:
        consider = np.abs(orb.deciding_multipliers)
    mx = float(np.max(consider))
    err = orb.multiplier_uncertainty
    if not math.isfinite(err):
        e = np.asarray(orb.multiplier_error, dtype=float)
        err = float(np.max(e)) if e.size else 0.0
    lam = math.log(mx) / orb.period if mx > 0 else -math.inf
    unc = (err / mx / orb.period) if mx > 0 else math.nan
    return lam, unc, float(err)


def census(system, starts: int = DEFAULTS["starts"], *, sampler=None, seed: int = 0,
           transient: int | None = None, record: int | None = None, rtol: float | None = None,
           max_period: int = DEFAULTS["max_period"], period_tol: float = DEFAULTS["period_tol"],
           match_factor: float = DEFAULTS["match_factor"],
           lyapunov_members: int = DEFAULTS["lyapunov_members"],
           rate_spread: float = DEFAULTS["rate_spread"], escape: float = DEFAULTS["escape"],
           workers: int = 1, dask=None, check: bool = True, progress=None,
           section=None) -> CensusResult:
    """The attractors reached from ``starts`` seeded starting states (module docstring).

    system: a forced flow (a scene system: ``SceneSystem``; a ContinuousSystem with a period), a
    map (``DiscreteMap``), or an autonomous flow through a Poincaré map: a
    :class:`nld.systems.PoincareMap`, or the flow with ``section=(normal, offset[,
    direction])`` (the hyperplane normal . y = offset crossed in direction +1 or -1; the
    census's period is then one return). sampler: the starts (default for a scene: its
    assembled state spread across the clearance circles; otherwise required: ``sampler(rng) ->
    y`` or ``(y, z)``, or a box ``(lo, hi)``; the flow's states for a Poincaré map).
    transient / record: periods (map: iterations; Poincaré map: returns) discarded and
    recorded per run (defaults 50 / 100; maps 1000 / 200). rtol: the integrations' tolerance
    (default ``nld.settings.LYAPUNOV.rtol``). workers / dask: the runs and exponents of a
    scene on a local process pool or a Dask cluster (``nld.sweeps.executors``; each worker
    builds the scene's system from its compiled kernel); other systems run in this process.
    check: recompute λ1 of every chaotic or quasi-periodic attractor at CHECK_RTOL x rtol over
    CHECK_SPAN x the span from the same state; its ``verdict`` holds only if both agree (else
    "not established", nld.analysis.verdict). Periodic attractors are the orbits of Newton
    shooting (``nld.analysis.orbits.periodic_orbit``) that their runs lie on (module
    docstring, step 3). The other settings: module docstring, DEFAULTS.
    The result does not depend on where the runs ran.
    """
    import pandas as pd
    from nld.analysis.lyapunov import check_seed
    from nld.analysis.verdict import (CHAOTIC, NOT_ESTABLISHED, exponent_verdict, kind_verdict,
                                      verdict as verdict_rule)
    from nld.progress import progress_bar
    from nld.sweeps.executors import check_workers
    starts = _check_int("starts", starts, 1)
    seed = check_seed(seed)
    max_period = _check_int("max_period", max_period, 1)
    lyapunov_members = _check_int("lyapunov_members", lyapunov_members, 1)
    if workers is not None:
        check_workers(workers)
    for nm, v in (("transient", transient), ("record", record)):
        if v is not None:
            _check_int(nm, v, 0 if nm == "transient" else 16)
    if not (0 < period_tol < 1):
        raise InputError(f"period_tol = {period_tol!r}: must be in (0, 1)")
    if section is not None:
        if system.is_map or system.period is not None:
            raise InputError("section: only for an autonomous flow (a forced flow is sampled "
                             "once per forcing period, a map is its own section)")
        if not isinstance(section, (tuple, list)) or len(section) not in (2, 3):
            raise InputError(f"section = {section!r}: must be (normal, offset) or (normal, "
                             f"offset, direction)")
        system = PoincareMap(system, section[0], section[1],
                             section[2] if len(section) == 3 else 1, rtol=rtol)
        rtol = None
    ctx = _context(system, rtol, transient, record, max_period, period_tol, match_factor, escape)
    sample = _as_sampler(system, sampler, rate_spread)
    rng = np.random.default_rng(seed)
    starts_yz = [sample(rng) for _ in range(starts)]
    payload = _payload(system, ctx, workers, dask)
    runs = [None] * starts
    with progress_bar(total=starts, desc=f"census {system.name}", unit="start",
                      enabled=progress, delay=2.0) as pb:
        for rec in _execute(_census_start, payload, ctx,
                            [(i, y, z) for i, (y, z) in enumerate(starts_yz)], workers, dask):
            runs[rec["index"]] = rec["run"]
            pb.update(1)
    # step 3: near-periodic runs polished by Newton shooting; a run on a stable orbit is periodic
    orbits: list = []
    for r in runs:
        if r.status == "ok" and not r.permanent and r.near:
            r.orbit = _assign_orbit(ctx, orbits, r, r.near)
        if r.orbit < 0 and r.period and not _whole_onsets(r):
            r.period = 0        # a fractional number of onsets per period: not periodic
    on_orbit = {i for i, r in enumerate(runs) if r.orbit >= 0}
    groups = _group(ctx, runs, skip=on_orbit)
    labels = np.full(starts, -2, dtype=np.int64)
    kinds = [""] * starts
    for i, r in enumerate(runs):
        if r.status == "escaping":
            kinds[i] = "escaping"
    attractors = []
    unsettled = []
    pname = system.period_name or ("iteration" if system.is_map else "period")
    by_orbit = {}
    for i in sorted(on_orbit):
        by_orbit.setdefault(runs[i].orbit, []).append(i)
    members = ([m for g in groups for m in g[:lyapunov_members]]
               + [m for g in by_orbit.values() for m in g[:lyapunov_members]])
    lams = {rec["index"]: rec["lambda"]
            for rec in _execute(_census_exponent, payload, ctx,
                                [(m, runs[m], seed) for m in members], workers, dask)}
    for g in groups:
        head = runs[g[0]]
        lam_runs = [(m,) + lams[m][:2] for m in g[:lyapunov_members]]
        las = np.array([v[1] for v in lam_runs])
        uns = np.array([v[2] for v in lam_runs])
        fin = np.isfinite(las)
        lam = float(np.mean(las[fin])) if fin.any() else math.nan
        unc = (float(np.max(uns[fin]) + 0.5 * (np.max(las[fin]) - np.min(las[fin])))
               if fin.any() else math.nan)
        periods = {runs[i].period for i in g}
        period = periods.pop() if len(periods) == 1 else 0
        if head.permanent:
            kind = "permanent contact"
        elif head.period:
            kind = "periodic"
        else:
            v = exponent_verdict(lam, unc)
            kind = (CHAOTIC if v == CHAOTIC else
                    "quasi-periodic" if v == "uncertain" and unc <= QUASI_PERIODIC_UNC
                    else "unsettled")
        if kind == "unsettled":
            # a run converging (λ1 < 0, or not resolved) without passing the period test: Newton
            # from its end at the period of its closest returns; on a stable orbit that it
            # approaches, it is periodic
            rest = []
            for i in g:
                p = _best_period(ctx, runs[i])
                k = _assign_orbit(ctx, orbits, runs[i], p, approach=True) if p else -1
                if k >= 0:
                    runs[i].orbit = k
                    by_orbit.setdefault(k, []).append(i)
                else:
                    rest.append(i)
            g = rest
            if not g:
                continue
            head = runs[g[0]]
        word, chk = kind_verdict(kind), None
        if kind in (CHAOTIC, "quasi-periodic") and check:
            # the verdict holds only across a change of tolerance and averaging span on the same
            # motion (nld.analysis.verdict): the first run again at CHECK_RTOL x rtol, CHECK_SPAN x
            # the span, from the same state
            lh, uh = lams[g[0]][:2]
            lc, uc, _ = _exponent(ctx, head, seed, CHECK_RTOL, CHECK_SPAN)
            chk = (lc, uc)
            if kind == CHAOTIC:
                word = verdict_rule(lh, uh, lam_check=lc, unc_check=uc)
            elif not (math.isfinite(lc) and abs(lc) <= max(uc, QUASI_PERIODIC_UNC)):
                word = NOT_ESTABLISHED
        if kind == "unsettled":
            unsettled.extend(g)
            for i in g:
                kinds[i] = "unsettled"
                labels[i] = -1
            continue
        mem = None
        if head.permanent:
            mem = {}
            for i in g:
                for k, v in runs[i].memory.items():
                    a, b = mem.get(k, (v, v))
                    mem[k] = (min(a, v), max(b, v))
        ons = [runs[i].onsets for i in g if math.isfinite(runs[i].onsets)]
        per_orbit = None
        if kind == "periodic" and period:
            # the whole number per period of the settled window (_whole_onsets checked it)
            blocks = [_onset_blocks(runs[i], period, max(16, runs[i].X.shape[0] // 2))
                      for i in g]
            got = {int(b[0]) for b in blocks if b is not None and b.size}
            if len(got) == 1:
                per_orbit = got.pop()
                ons = [per_orbit / period]
        note = ("orbits of a continuum selected by the recorded memory (history-dependent)"
                if head.permanent else
                "not polished: Newton shooting did not converge to a stable orbit from its runs"
                if kind == "periodic" else "")
        attractors.append(Attractor(
            id=0, kind=kind, period=int(period), count=len(g), fraction=len(g) / starts,
            fraction_interval=wilson_interval(len(g), starts), points=head.X[-64:].copy(),
            lambda1=lam, lambda1_uncertainty=unc, lambda1_runs=lam_runs,
            onsets_per_period=float(np.mean(ons)) if ons else math.nan,
            conditional_on_memory=mem, runs=list(g), verdict=word,
            lambda1_check=chk[0] if chk else math.nan,
            lambda1_check_uncertainty=chk[1] if chk else math.nan, note=note,
            onsets_per_orbit=per_orbit))
        for i in g:
            kinds[i] = kind
    for k, g in sorted(by_orbit.items()):
        orb = orbits[k]
        lam_runs = [(m,) + lams[m][:2] for m in g if m in lams][:max(lyapunov_members, 1)]
        las = np.array([v[1] for v in lam_runs], dtype=float)
        uns = np.array([v[2] for v in lam_runs], dtype=float)
        fin = np.isfinite(las)
        lt = float(np.mean(las[fin])) if fin.any() else math.nan
        ut = (float(np.max(uns[fin]) + 0.5 * (np.max(las[fin]) - np.min(las[fin])))
              if fin.any() else math.nan)
        if ctx["kind"] == "poincare":
            # an autonomous flow's λ1 on a limit cycle is that of the flow direction, 0: the
            # tangent estimate checks nothing here
            lt = ut = math.nan
        lam, unc, err = _orbit_lambda(orb)
        ons = int(orb.onsets_per_period) if orb.onsets.size else None
        stab = orb.stability
        attractors.append(Attractor(
            id=0, kind="periodic", period=int(orb.period), count=len(g),
            fraction=len(g) / starts, fraction_interval=wilson_interval(len(g), starts),
            points=np.array(orb.points), lambda1=lam, lambda1_uncertainty=unc,
            lambda1_runs=lam_runs,
            onsets_per_period=(ons / orb.period) if ons is not None else math.nan,
            runs=sorted(g), verdict=kind_verdict("periodic"), onsets_per_orbit=ons,
            multipliers=np.array(orb.multipliers), multiplier_error=err,
            orbit_residual=float(orb.residual), orbit=orb, lambda1_tangent=lt,
            lambda1_tangent_uncertainty=ut,
            note="" if stab == "stable" else f"orbit stability {stab}"))
        for i in g:
            kinds[i] = "periodic"
    escaping = [i for i, r in enumerate(runs) if r.status == "escaping"]
    if escaping:
        attractors.append(Attractor(id=0, kind="escaping", period=0, count=len(escaping),
                                    verdict=kind_verdict("escaping"),
                                    fraction=len(escaping) / starts,
                                    fraction_interval=wilson_interval(len(escaping), starts),
                                    points=np.zeros((0, ctx["n"])), runs=escaping))
    attractors.sort(key=lambda a: -a.count)
    for k, a in enumerate(attractors):
        a.id = k
        for i in a.runs:
            labels[i] = k
    failed = sum(1 for r in runs if r.status == "failed")
    for i, r in enumerate(runs):
        if r.status == "failed":
            kinds[i] = "failed"
    table = pd.DataFrame({"start": np.arange(starts), "attractor": labels, "kind": kinds,
                          "period": [orbits[r.orbit].period if r.orbit >= 0 else r.period
                                     for r in runs],
                          "onsets_per_period": [r.onsets for r in runs],
                          "permanent_contact": [r.permanent for r in runs],
                          "message": [r.message for r in runs]})
    settings = dict(starts=starts, seed=seed, transient=ctx["transient"], record=ctx["record"],
                    rtol=ctx["rtol"], max_period=max_period, period_tol=period_tol,
                    near_tol=NEAR_TOL if ctx["kind"] != "map" else None,
                    match_factor=match_factor, lyapunov_members=lyapunov_members,
                    rate_spread=rate_spread, escape=escape,
                    section=(repr(system) if ctx["kind"] == "poincare" else ctx["kind"]),
                    orbits="Newton shooting (nld.analysis.orbits.periodic_orbit) from the runs "
                           "that are near-periodic or converge (λ1 < 0)",
                    lyapunov="tangent, %d %ss from the end of the section" % (
                        ctx["record_lyap"], pname),
                    sampler="scene default" if sampler is None else repr(sampler),
                    check=(f"chaotic / quasi-periodic attractors: λ1 again at {CHECK_RTOL:g} x rtol "
                           f"over {CHECK_SPAN:g} x the span" if check else "none"))
    names = (ctx["map"].state_names if ctx["map"] is not None else system.state_names)
    return CensusResult(system=system.name, attractors=attractors, n_starts=starts,
                        unsettled=len(unsettled), failed=failed, runs=table, settings=settings,
                        period_name=pname, state_names=list(names),
                        scales=np.asarray(ctx["scales"]), angles=np.asarray(ctx["angles"]))


# ---------------------------------------------------------------- across a parameter
SWEEP_SETTINGS = ("scene", "param", "values", "starts", "seed", "transient", "record", "rtol",
                  "max_period", "overrides")
MATCH_DISTANCE = 0.25


def _sweep_point(payload, index: int, value: float) -> dict:
    """One parameter value of :func:`census_sweep`: its census (never raises for a failed run)."""
    import time
    import pandas as pd
    from nld.systems.core import SceneSystem
    from nld.model.scene import resolve_scene
    t0 = time.perf_counter()
    kw = payload["census"]
    try:
        scene = resolve_scene(payload["scene"], list(payload["overrides"])
                              + [f"{payload['param']}={value!r}"])
        res = census(SceneSystem(scene), progress=False, **kw)
        rows = []
        for a in res.attractors:
            for k, x in enumerate(a.points):
                rows.append({"attractor": a.id, "k": k, **dict(zip(res.state_names, x))})
        table = pd.DataFrame(rows) if rows else pd.DataFrame({"attractor": [-1], "k": [-1]})
        meta = dict(status="ok", message="", census=res.to_dict(),
                    state_names=list(res.state_names), scales=list(res.scales),
                    angles=list(res.angles))
    except (InputError, SolveError) as e:
        table = pd.DataFrame({"attractor": [-1], "k": [-1]})
        meta = dict(status="failed", message=" ".join(str(e).split()), census=None)
    return dict(direction="census", index=int(index), value=float(value), table=table,
                wall=time.perf_counter() - t0, **meta)


def match_attractors(records: list) -> "object":
    """Attractors matched across neighbouring parameter values (Datseris, Rossi & Wagemakers,
    "Framework for global stability analysis of dynamical systems", Chaos 33, 073151, 2023:
    matching by distance of the attractors' sets). records: the sweep's point records in
    parameter order. Returns a DataFrame, one row per (value, attractor): value, label (the
    identity kept across values), kind, period, fraction, fraction_lo/hi, lambda1,
    lambda1_uncertainty, onsets_per_period, count; and per value the unsettled fraction (label
    -1). An attractor at one value takes the label of the closest attractor of the same kind at
    the previous value when their set distance is at most MATCH_DISTANCE x the scaled extent of
    all the attractors of both values together (escaping matches escaping, permanent contact matches permanent
    contact); otherwise it gets a new label."""
    import pandas as pd
    rows = []
    prev: list = []          # (label, kind, points) at the previous value
    next_label = 0
    for rec in records:
        c = rec.get("census")
        if rec.get("status") != "ok" or not c:
            rows.append(dict(value=rec["value"], label=-2, kind="failed", period=0,
                             fraction=math.nan, fraction_lo=math.nan, fraction_hi=math.nan,
                             lambda1=math.nan, lambda1_uncertainty=math.nan,
                             onsets_per_period=math.nan, count=0))
            prev = []
            continue
        tab = rec["table"]
        scales = np.asarray(rec["scales"], dtype=float)
        angles = np.asarray(rec["angles"], dtype=np.int64)
        names = rec["state_names"]
        cur = []
        for a in c["attractors"]:
            pts = tab[tab["attractor"] == a["id"]][names].to_numpy(dtype=float) \
                if len(tab) and set(names) <= set(tab.columns) else np.zeros((0, len(names)))
            cur.append((a, pts))
        both = [p for _, p in cur if p.shape[0]] + [p for _, _, p in prev if p.shape[0]]
        ext = _extent(np.concatenate(both), scales) if both else 0.0
        cand = []
        for j, (a, pts) in enumerate(cur):
            for i, (lab, kind, ppts) in enumerate(prev):
                if kind != a["kind"]:
                    continue
                if kind in ("escaping", "permanent contact"):
                    cand.append((0.0, j, i))
                    continue
                if pts.shape[0] == 0 or ppts.shape[0] == 0:
                    continue
                d = set_distance(pts, ppts, scales, angles)
                if d <= MATCH_DISTANCE * ext + 1e-12:
                    cand.append((d, j, i))
        cand.sort()
        got, used = {}, set()
        for d, j, i in cand:
            if j not in got and i not in used:
                got[j] = prev[i][0]
                used.add(i)
        new_prev = []
        for j, (a, pts) in enumerate(cur):
            if j not in got:
                got[j] = next_label
                next_label += 1
            lo, hi = a["fraction_interval"]
            rows.append(dict(value=rec["value"], label=got[j], kind=a["kind"], period=a["period"],
                             fraction=a["fraction"], fraction_lo=lo, fraction_hi=hi,
                             lambda1=_nan(a["lambda1_per_revolution"]),
                             lambda1_uncertainty=_nan(a["lambda1_uncertainty"]),
                             onsets_per_period=_nan(a["onsets_per_period"]), count=a["count"]))
            new_prev.append((got[j], a["kind"], pts))
        if c["unsettled"]:
            n = c["n_starts"]
            lo, hi = wilson_interval(c["unsettled"], n)
            rows.append(dict(value=rec["value"], label=-1, kind="unsettled", period=0,
                             fraction=c["unsettled"] / n, fraction_lo=lo, fraction_hi=hi,
                             lambda1=math.nan, lambda1_uncertainty=math.nan,
                             onsets_per_period=math.nan, count=c["unsettled"]))
        prev = new_prev
    return pd.DataFrame(rows)


def _nan(v):
    return math.nan if v is None else float(v)


def census_sweep(scene, param: str, values, *, overrides=(), out=None, resume: bool = False,
                 workers=None, dask=None, progress=None, provenance: dict | None = None,
                 **census_kw):
    """The census at every value of one scene parameter, attractors matched across the values
    (:func:`match_attractors`). scene: a built-in scene name, TOML path or Scene; param: a scene
    key (``joints.B.clearance``); values: the parameter values (SI); overrides: more ``KEY=V``.
    On the sweep engine (``nld.sweeps``): each value a point run on ``workers`` local processes
    or Dask, written to ``out`` (one file per finished value) as it finishes; ``resume``
    continues an interrupted sweep; Ctrl-C keeps the finished values (Interrupted). census_kw:
    the settings of :func:`census` (starts, seed, transient, record, rtol, ...).
    Returns (table of :func:`match_attractors`, records in value order)."""
    from nld.model.scene import resolve_scene
    from nld.sweeps.engine import run_points
    from nld.sweeps.store import ResultStore
    values = [float(v) for v in values]
    if not values or not all(math.isfinite(v) for v in values):
        raise InputError(f"values = {values!r}: give finite parameter values")
    base = resolve_scene(scene, list(overrides))
    for v in values:            # the key and every value checked before any run
        resolve_scene(base, [f"{param}={v!r}"])
    bad = set(census_kw) - {"starts", "seed", "transient", "record", "rtol", "max_period",
                            "period_tol", "match_factor", "lyapunov_members", "rate_spread",
                            "escape"}
    if bad:
        raise InputError(f"census_sweep: unknown setting {sorted(bad)[0]!r}")
    payload = dict(scene=scene if isinstance(scene, str) else base, overrides=list(overrides),
                   param=param, census=dict(census_kw))
    store, done = None, {}
    if out is not None:
        store = ResultStore(out)
        prov = dict(provenance or {})
        prov.update(scene=base.name, param=param, values=values, overrides=list(overrides),
                    **{k: census_kw.get(k) for k in ("starts", "seed", "transient", "record",
                                                      "rtol", "max_period")})
        store.prepare(prov, settings=SWEEP_SETTINGS, resume=resume, what="census sweep")
        done = store.finished() if resume else {}
    items = [(i, v) for i, v in enumerate(values) if ("census", i) not in done]
    results = run_points(_sweep_point, payload, items, done=done, store=store, workers=workers,
                         dask=dask, progress=progress, desc=f"census {base.name}", unit="value",
                         what="values")
    records = [results[("census", i)] for i in range(len(values)) if ("census", i) in results]
    return match_attractors(records), records
