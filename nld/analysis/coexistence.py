"""Coexisting motions at a set of points: the attractor census (:func:`nld.analysis.attractors.census`)
at each point of a scene whose verdict was not established, as one table with a row per attractor,
and the census verdict of each point (issue 39: the workflow the studies share, moved below the
front ends from nld/study.py; the report page stays there, ``nld.study.census_page``).

The census verdict (:func:`nld.analysis.verdict.census_verdict`: ``coexisting`` for more than one
attractor, else the one attractor's class) replaces ``not established``
(docs/attractors.md, "Verdicts")."""
from __future__ import annotations

from typing import Callable, Mapping, Sequence

__all__ = ["CENSUS_COLUMNS", "census_points", "census_verdicts"]

CENSUS_COLUMNS = ["point", "verdict_before", "census_verdict", "attractor", "kind", "period",
                  "fraction", "fraction_lo", "fraction_hi", "lambda1_per_rev",
                  "lambda1_unc_per_rev", "onsets_per_rev", "onsets_per_orbit", "max_abs_mu",
                  "count", "starts", "memory"]


def census_points(scene, points: Mapping[str, tuple[Sequence[str], str]], *, starts: int,
                  transient: int, record: int, rtol: float, seed: int = 0, workers: int = 1,
                  stage: Callable[[str], None] | None = None):
    """The attractor census at each point: a DataFrame, columns :data:`CENSUS_COLUMNS`, one row
    per attractor (and one per point for its unsettled runs, ``kind`` "unsettled").

    scene: a built-in scene name, .toml path or Scene; points: ``{label: (overrides "KEY=VALUE",
    verdict before)}``. starts: seeded starts per point; transient, record: revolutions of
    transient and recorded per start; rtol: relative tolerance; seed: the starts' seed; workers:
    processes of each census; stage: a callable given a progress line per point. Fractions are
    shares of the starts with their Wilson 95 % interval (fraction_lo, fraction_hi); lambda1 and
    onsets per crank revolution; memory: the range of the contact memory (m/s) a permanent-contact
    motion depends on."""
    import numpy as np
    import pandas as pd
    from nld.analysis.attractors import census
    from nld.systems.core import SceneSystem
    rows = []
    for label, (ov, before) in points.items():
        if stage is not None:
            stage(f"census at {label}")
        res = census(SceneSystem(scene, list(ov)), starts, transient=transient, record=record,
                     rtol=rtol, seed=seed, workers=workers)
        for a in res.attractors:
            mem = ("" if not a.conditional_on_memory else "; ".join(
                f"{k} {lo:.3g}..{hi:.3g} m/s" for k, (lo, hi) in a.conditional_on_memory.items()))
            rows.append(dict(point=label, verdict_before=before, census_verdict=res.verdict,
                             attractor=a.id, kind=a.kind, period=a.period, fraction=a.fraction,
                             fraction_lo=a.fraction_interval[0],
                             fraction_hi=a.fraction_interval[1], lambda1_per_rev=a.lambda1,
                             lambda1_unc_per_rev=a.lambda1_uncertainty,
                             onsets_per_rev=a.onsets_per_period,
                             onsets_per_orbit=(a.onsets_per_orbit if a.onsets_per_orbit
                                               is not None else float("nan")),
                             max_abs_mu=(float(np.max(np.abs(a.multipliers)))
                                         if a.multipliers is not None and len(a.multipliers)
                                         else float("nan")),
                             count=a.count, starts=res.n_starts, memory=mem))
        if res.unsettled or not res.attractors:
            lo, hi = res.unsettled_interval
            rows.append(dict(point=label, verdict_before=before, census_verdict=res.verdict,
                             attractor=-1, kind="unsettled", period=0,
                             fraction=res.unsettled / res.n_starts, fraction_lo=lo,
                             fraction_hi=hi, lambda1_per_rev=float("nan"),
                             lambda1_unc_per_rev=float("nan"), onsets_per_rev=float("nan"),
                             onsets_per_orbit=float("nan"), max_abs_mu=float("nan"),
                             count=res.unsettled, starts=res.n_starts, memory=""))
    return pd.DataFrame(rows, columns=CENSUS_COLUMNS)


def census_verdicts(df) -> dict:
    """{point: census verdict} of a :func:`census_points` table."""
    return {} if df is None or not len(df) else \
        dict(zip(df["point"], df["census_verdict"]))
