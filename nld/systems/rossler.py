"""The Rössler system (O. E. Rössler, "An equation for continuous chaos", Phys. Lett. A 57 (1976)
397-398, eq. 2), the reference flow of delayed-feedback control (K. Pyragas, Phys. Lett. A 170
(1992) 421-428, section 3; nld.analysis.control, docs/control.md).

Units: dimensionless (the time unit is the system's own).
"""
from __future__ import annotations

from numba import njit

from nld.systems.core import ContinuousSystem

__all__ = ["rossler", "rossler_rhs"]


def rossler(a: float = 0.2, b: float = 0.2, c: float = 5.7, y0=(1.0, 1.0, 1.0)) -> ContinuousSystem:
    """The Rössler system x' = -y - z, y' = x + a y, z' = b + z (x - c) (Rössler 1976), at
    Pyragas' (1992) a = b = 0.2, c = 5.7 chaotic (lambda1 ~ 0.07 per time unit) with a period-1
    unstable orbit of period ~ 5.88 (docs/control.md: found by periodic_orbit)."""
    s = ContinuousSystem(rossler_rhs, y0, [a, b, c], f"rossler(a={a:g}, b={b:g}, c={c:g})",
                         ["x", "y", "z"])
    s.param_names = ["a", "b", "c"]
    return s


@njit(cache=True)
def rossler_rhs(t, y, p, z, dy):
    """Rössler (1976); p = [a, b, c]."""
    dy[0] = -y[1] - y[2]
    dy[1] = y[0] + p[0] * y[1]
    dy[2] = p[1] + y[2] * (y[0] - p[2])
