"""Per-revolution maxima located from the dense output (not limited by the output sampling).

    from nld.analysis.extrema import revolution_maxima
    run = revolution_maxima("excavator", ["rod.omega", "A.Fn"], revs=20, transient_revs=2,
                            rtol=1e-7, samples_per_rev=14400, keep_every=10)
    run.maxima          # one row per (revolution, column): sampled, detected and refined peak
    run.table           # every keep_every-th sample of the first keep_revs revolutions

Impacts in a clearance joint last tens of microseconds; a peak read off output samples spaced a
fraction of a millisecond apart can be far below the true one (the excavator's rod angular
velocity: +36 % at 40x the samples). The run here integrates one crank revolution per call of the
kernel's compiled integrator (as ``nld.run.simulate`` does with ``chunk_revs = 1``), keeping the
continuous and discrete state at every *detection* sample. In each revolution and for each
column, the ``refine_top`` largest local maxima of the detection samples are refined:

1. the window between the samples either side of the candidate is integrated again from the
   stored state at its left end (same tolerances, fresh step-size start), with ``dense`` + 1
   output points interpolated by the integrator's dense output;
2. the window shrinks to the output points either side of the largest value found and step 1
   repeats, until the peak changes by at most ``peak_rtol`` (relative) between two zoom levels
   (at least two levels) or the window is narrower than ``min_width`` s.

The refined peak is the largest value of the column at any time evaluated (detection samples and
refinement points), so it is never below the sampled maximum. A candidate is a local maximum of
the samples; a spike that falls entirely between two detection samples without raising either
is not found (``samples_per_rev`` sets that limit; the convergence of the per-revolution maxima
with it is what the zhang2013 study reports). Re-integrating a window restarts the integrator,
which moves the solution by an error of the order of the tolerance.

The maxima are of ``|column|`` when ``absolute`` (default), else of the signed value.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from nld.errors import InputError, SolveError
from nld.integrators.core import as_solution

__all__ = ["RevolutionRun", "revolution_maxima", "window_peak", "candidates"]


@dataclass
class RevolutionRun:
    table: pd.DataFrame       # kept samples (t and every kernel column), revolutions < keep_revs
    maxima: pd.DataFrame      # rev, column, sampled, detected, peak, t_peak, iterations, ...
    y_final: np.ndarray
    z_final: np.ndarray
    stats: dict               # integrator statistics of the main run and of the refinement
    status: int
    message: str
    t_reached: float
    events: int               # located events of the main run
    wall_s: float
    settings: dict = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return self.status >= 0


def candidates(v: np.ndarray, k: int) -> np.ndarray:
    """Indices of the ``k`` largest local maxima of ``v`` (plateaus and end points included),
    largest first."""
    v = np.asarray(v, float)
    n = v.size
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    left = np.empty(n, bool)
    right = np.empty(n, bool)
    left[0] = right[-1] = True
    left[1:] = v[1:] >= v[:-1]
    right[:-1] = v[:-1] >= v[1:]
    idx = np.flatnonzero(left & right)
    order = np.argsort(-v[idx], kind="stable")
    return idx[order[:max(1, int(k))]]


def window_peak(solve, observe_all, ncols, col, absolute, ta, tb, y_a, z_a, p, rtol, atol, hmax,
                n_events, *, dense=32, peak_rtol=1e-6, min_width=1e-12, max_iter=40,
                max_steps=2_000_000, best=-math.inf, t_best=math.nan):
    """Zoom on the largest value of column ``col`` in [ta, tb], starting from state (y_a, z_a) at
    ta (see the module docstring). Returns (peak, t_peak, iterations, final width, converged,
    steps)."""
    width = tb - ta
    converged = False
    steps = 0
    it = 0
    prev = best
    for it in range(1, max_iter + 1):
        tt = np.linspace(ta, tb, dense + 1)
        zz = np.array(z_a, dtype=float)
        out = solve(float(ta), np.ascontiguousarray(y_a, dtype=float), tt, False, p, zz, rtol, atol,
                    0.0, hmax, int(max_steps), int(n_events), 64)
        out = as_solution(out)
        status, n_out, st, Y, Z = int(out.status), int(out.n_out), out.stats, out.Y, out.Z
        steps += int(st[0])
        if status < 0 or n_out < tt.size:
            raise SolveError(f"refinement window [{ta:.9g}, {tb:.9g}] s: integration stopped "
                             f"(status {status})")
        rows = np.empty((tt.size, ncols))
        observe_all(tt, Y, Z, tt.size, p, rows)
        v = np.abs(rows[:, col]) if absolute else rows[:, col]
        j = int(np.argmax(v))
        if v[j] > best:
            best, t_best = float(v[j]), float(tt[j])
        lo, hi = max(j - 1, 0), min(j + 1, dense)
        width = float(tt[hi] - tt[lo])
        if it >= 2 and abs(best - prev) <= peak_rtol * abs(best):
            converged = True
            break
        if width < min_width:
            converged = True
            break
        prev = best
        y_a, z_a, ta, tb = Y[lo].copy(), Z[lo].copy(), tt[lo], tt[hi]
    return best, t_best, it, width, converged, steps


def revolution_maxima(scene, columns, *, revs: int, transient_revs: int = 0, rtol: float = 1e-7,
                      samples_per_rev: int = 14400, keep_every: int = 10, keep_revs: int | None = None,
                      refine_top: int = 4, peak_rtol: float = 1e-6, dense: int = 32,
                      min_width: float = 1e-12, max_iter: int = 40, absolute=True, overrides=None,
                      max_steps: int = 200_000_000, max_steps_per_rev: int | None = None, kernel=None,
                      progress=None, y0=None, z0=None) -> RevolutionRun:
    """Run ``transient_revs + revs`` crank revolutions from the assembled state and locate the
    maximum of each of ``columns`` in each of the last ``revs`` revolutions (module docstring).

    samples_per_rev: detection samples per revolution; keep_every: the kept table holds every
    keep_every-th of them (its sampling is samples_per_rev / keep_every per revolution);
    keep_revs: revolutions kept in the table (default all, transient included; a column
    ``steady`` marks the statistics part). absolute: bool or a dict column -> bool. max_steps: for
    the whole run; max_steps_per_rev: for any one revolution (a run whose step count explodes,
    e.g. by mode chatter, stops there with the integrator's message instead of running on).
    y0: start from this state (independent coordinates then speeds, the kernel's order; e.g. a
    seeded perturbation of the assembled state for an independent realisation,
    nld.analysis.peaks) instead of the assembled one; the modes are set from it. z0: the discrete
    state to go on with (e.g. the ``z_final`` of a run ended at a whole revolution, with y0 its
    ``y_final``: contact modes and onset memory continue, as ``nld.run.simulate(y0=, z0=)``);
    given, the modes are not reset from y0, except the branches of switched loads, which the
    time decides (set from y0 at t = 0, as ``simulate`` does).
    maxima columns: ``rev`` (0 = first revolution after the transient), ``column``, ``t_start``
    (s), ``sampled`` (max over the kept samples of the revolution), ``detected`` (max over the
    detection samples), ``peak`` (refined), ``t_peak`` (s), ``iterations`` (zoom levels, summed
    over the candidates), ``width`` (s, final window of the winning candidate), ``converged``.
    """
    from nld.integrators.dopri5 import status_message
    from nld.kernel.compile import compile_scene
    from nld.progress import progress_bar
    from nld.run.simulate import check_int, crank_period, event_log_size, initial_state, tolerances
    start = time.perf_counter()
    revs = check_int("revs", revs, 1)
    transient_revs = check_int("transient_revs", transient_revs, 0)
    samples_per_rev = check_int("samples_per_rev", samples_per_rev, 2)
    keep_every = check_int("keep_every", keep_every, 1)
    refine_top = check_int("refine_top", refine_top, 0)
    if samples_per_rev % keep_every:
        raise InputError(f"keep_every = {keep_every}: must divide samples_per_rev = {samples_per_rev}")
    if not (isinstance(peak_rtol, float | int) and 0 < peak_rtol < 1):
        raise InputError(f"peak_rtol = {peak_rtol!r}: must be a number in (0, 1)")
    if isinstance(columns, str):
        columns = [columns]
    from nld.model.scene import resolve_scene
    scene = resolve_scene(scene, overrides)
    kern = kernel if kernel is not None else compile_scene(scene)
    unknown = [c for c in columns if c not in kern.columns]
    if unknown:
        raise InputError(f"columns: {', '.join(unknown)} not outputs of scene {scene.name!r}")
    if kern.n_state == 0:
        raise InputError(f"scene {scene.name!r} has no free coordinates: nothing to integrate")
    absf = {c: bool(absolute.get(c, True)) if isinstance(absolute, dict) else bool(absolute)
            for c in columns}
    cidx = {c: kern.columns.index(c) for c in columns}
    p = kern.params(scene)
    period = crank_period(scene, "revs")
    y, z, q_init = initial_state(kern)
    if y0 is not None:
        y0 = np.asarray(y0, dtype=float)
        if y0.shape != y.shape or not np.all(np.isfinite(y0)):
            raise InputError(f"y0: must be {y.size} finite numbers (independent coordinates then "
                             f"speeds of scene {scene.name!r}), got shape {y0.shape}")
        y = y0.copy()
    if z0 is not None:
        z0 = np.asarray(z0, dtype=float)
        if z0.shape != np.shape(z) or not np.all(np.isfinite(z0)):
            raise InputError(f"z0: must be {np.size(z)} finite numbers (the discrete state of scene "
                             f"{scene.name!r}), got shape {z0.shape}")
        z = z0.copy()
        relabel = kern.time_labels()
        if relabel is not None:
            # the run restarts at t = 0 whatever time z0 was reached at: the switched loads'
            # branches from (0, y), as simulate does (nld.systems.core.restart_labels)
            relabel(0.0, y, p, z)
    else:
        z = np.array(z, dtype=float)
        kern.init_modes(0.0, y, p, z)
    atol = tolerances(kern, q_init, rtol)
    hmax = period / 20.0
    solve, observe_all = kern.module.solve, kern.module.observe_all
    n_ev = kern.n_events
    ncols = len(kern.columns)
    total = transient_revs + revs
    keep_revs = total if keep_revs is None else min(total, check_int("keep_revs", keep_revs, 0))
    max_log = max(64, min(event_log_size(1.0), 50_000))
    base = np.linspace(0.0, period, samples_per_rev + 1)
    kept, rows_out = [], []
    t = 0.0
    h0 = 0.0
    steps_left = int(max_steps)
    st_main = np.zeros(5, dtype=np.int64)
    ref_steps = 0
    n_events_logged = 0
    status, message = 0, ""
    y = np.ascontiguousarray(y, dtype=float)
    from nld.interrupt import deferred
    interrupted = False
    # SIGINT is deferred while the compiled integrator runs (numba's result boxing crashes on a
    # pending KeyboardInterrupt) and honoured after the revolution in progress
    with deferred() as sig, progress_bar(total=total, unit="rev", desc=f"maxima {scene.name}",
                                         enabled=progress, delay=2.0) as bar:
        for k in range(total):
            if sig.requested:
                sig.handled = interrupted = True
                break
            te = np.ascontiguousarray(k * period + base)
            te[0] = t      # k * period can round 1 ulp above the end of the last revolution
            cap = steps_left if max_steps_per_rev is None else min(steps_left, int(max_steps_per_rev))
            out = solve(t, y, te, False, p, z, float(rtol), atol, h0, hmax, cap, n_ev, max_log)
            out = as_solution(out)
            st_k, t_k, Y, n_k, stats_k = int(out.status), float(out.t), out.Y, int(out.n_out), out.stats
            Z = out.Z
            stats_k = np.asarray(stats_k, dtype=np.int64)[:5]
            st_main += stats_k
            n_events_logged += int(out.n_ev)
            steps_left -= int(stats_k[0])
            rows = np.empty((n_k, ncols))
            observe_all(te, Y, Z, n_k, p, rows)
            if k < keep_revs:
                sel = np.arange(0, n_k, keep_every)
                if k < keep_revs - 1:
                    sel = sel[sel < samples_per_rev]   # the next revolution starts with that sample
                frame = pd.DataFrame(rows[sel], columns=kern.columns)
                frame.insert(0, "t", te[sel])
                kept.append(frame)
            if st_k != 0 or n_k < te.size:
                status = st_k if st_k < 0 else -1
                message = status_message(st_k, t_k, stats_k) if st_k < 0 else (
                    f"stopped at t = {t_k:.9g} s: {n_k} of {te.size} samples")
                t = t_k
                break
            if k >= transient_revs:
                r = k - transient_revs
                for c in columns:
                    ci = cidx[c]
                    v = np.abs(rows[:, ci]) if absf[c] else rows[:, ci]
                    sampled = float(v[::keep_every].max())
                    detected_i = int(np.argmax(v))
                    best, t_best = float(v[detected_i]), float(te[detected_i])
                    its, width, conv = 0, float(te[1] - te[0]), True
                    for i in candidates(v, refine_top) if refine_top else []:
                        lo, hi = max(i - 1, 0), min(i + 1, samples_per_rev)
                        pk, tp, it_, w, cv, nst = window_peak(
                            solve, observe_all, ncols, ci, absf[c], te[lo], te[hi], Y[lo], Z[lo], p,
                            float(rtol), atol, hmax, n_ev, dense=dense, peak_rtol=peak_rtol,
                            min_width=min_width, max_iter=max_iter, best=float(v[i]), t_best=float(te[i]))
                        its += it_
                        ref_steps += nst
                        if pk > best:
                            best, t_best, width, conv = pk, tp, w, cv
                        elif i == detected_i:
                            width, conv = w, cv
                    rows_out.append(dict(rev=r, column=c, t_start=float(te[0]), sampled=sampled,
                                         detected=float(v[detected_i]), peak=best, t_peak=t_best,
                                         iterations=its, width=width, converged=bool(conv)))
            acc = int(stats_k[1])
            h0 = min(hmax, period / acc) if acc > 0 else 0.0
            y = np.ascontiguousarray(Y[n_k - 1]).copy()
            t = float(te[-1])
            bar.update(1)
    if interrupted:
        from nld.run.simulate import INTERRUPTED
        status, message = INTERRUPTED, f"interrupted by Ctrl-C at t = {t:.9g} s"
    elif status == 0:
        message = (f"reached t_end = {t:.9g} s ({int(st_main[1])} steps, {int(st_main[2])} rejected; "
                   f"{ref_steps} steps in the refinement windows)")
    table = pd.concat(kept, ignore_index=True) if kept else pd.DataFrame(columns=["t", *kern.columns])
    table.insert(0, "steady", table["t"].to_numpy() >= transient_revs * period - 1e-12)
    maxima = pd.DataFrame(rows_out, columns=["rev", "column", "t_start", "sampled", "detected", "peak",
                                             "t_peak", "iterations", "width", "converged"])
    stats = dict(steps=int(st_main[0]), accepted=int(st_main[1]), rejected=int(st_main[2]),
                 rhs=int(st_main[3]), events=int(st_main[4]), refinement_steps=int(ref_steps))
    settings = dict(revs=revs, transient_revs=transient_revs, rtol=float(rtol),
                    samples_per_rev=samples_per_rev, keep_every=keep_every, keep_revs=keep_revs,
                    refine_top=refine_top, peak_rtol=float(peak_rtol), dense=dense,
                    min_width=min_width, max_iter=max_iter, period=period,
                    max_steps_per_rev=max_steps_per_rev)
    run = RevolutionRun(table, maxima, np.asarray(y, float), z, stats, int(status), message, float(t),
                        int(n_events_logged), time.perf_counter() - start, settings)
    if interrupted:
        from nld.errors import Interrupted
        done = int(maxima["rev"].max()) + 1 if len(maxima) else 0
        raise Interrupted(f"interrupted at t = {t:.9g} s", partial=run,
                          kept=f"the maxima of {done} of {revs} revolutions (Interrupted.partial)")
    return run
