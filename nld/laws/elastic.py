"""The elastic part shared by every contact law (docs/contact-laws.md): the Hertz stiffness of a
journal inside a bearing, the elastic force K delta^n and its stored energy.

The laws themselves are one file each in nld/laws/contact/ (registry: nld.laws.law).
"""
from __future__ import annotations

import math
import numbers

import numba


@numba.njit(cache=True, inline="always")
def elastic_force(delta, K, n):
    """The elastic (conservative) part K delta^n (N) of every law; 0 for delta <= 0 (Hertz point
    contact, references section 4; the seed paper's eqs 6 and 8 without damping).

    delta (m), K (N/m^n), n (-). The kernels' power balance takes the non-conservative part of a
    law as its force minus this."""
    if delta <= 0.0:
        return 0.0
    f = K * delta**n
    return max(f, 0.0)


@numba.njit(cache=True, inline="always")
def contact_energy(delta, K, n):
    """Potential energy of the elastic part K delta^n: V = K delta^(n+1) / (n+1) (J).

    delta (m), K (N/m^n), n (-). 0 for delta <= 0. Used by energy-balance checks: for ``hertz``
    the sum kinetic + contact_energy is conserved.
    """
    if delta <= 0.0:
        return 0.0
    return K * delta ** (n + 1.0) / (n + 1.0)


def _is_real(value):
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _check_positive_finite(name, value, unit):
    if not (_is_real(value) and math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name} = {value!r}: must be a finite number > 0 ({unit})")


def _check_poisson(name, value):
    if not (_is_real(value) and math.isfinite(value) and 0.0 <= value < 0.5):
        raise ValueError(f"{name} = {value!r}: must be in [0, 0.5) (-)")


def journal_bearing_stiffness(R_journal, R_bearing, E_journal, nu_journal, E_bearing, nu_bearing):
    """Hertz stiffness K (N/m^1.5) of a journal (radius R_journal) inside a bearing (R_bearing).

    K = 4 / (3 (sigma_i + sigma_j)) * sqrt(R_i R_j / (R_j - R_i)), sigma = (1 - nu^2) / E,
    i = journal, j = bearing (opposite curvatures, so the radii combine as R_i R_j / (R_j - R_i)).
    References section 4 (as used by Flores et al. for revolute clearance joints).

    The same law is often written with h = (1 - nu^2) / (pi E) and the prefactor
    4 / (3 pi (h_i + h_j)); both are identical. Mixing the conventions (sigma in the pi-form
    or h in the sigma-form) is a factor-pi error: 2.1e10 instead of 6.6e10 N/m^1.5 for the
    Flores joint (R_B = 10 mm, R_J = 9.5 mm, E = 207 GPa, nu = 0.3).

    Radii in m, Young's moduli in Pa, Poisson ratios dimensionless. Raises ValueError (one line)
    unless R_bearing > R_journal > 0, E > 0 and 0 <= nu < 0.5.
    """
    _check_positive_finite("R_journal", R_journal, "m")
    _check_positive_finite("R_bearing", R_bearing, "m")
    if not R_bearing > R_journal:
        raise ValueError(
            f"R_bearing = {R_bearing!r}: must be > R_journal = {R_journal!r} (m)"
        )
    _check_positive_finite("E_journal", E_journal, "Pa")
    _check_positive_finite("E_bearing", E_bearing, "Pa")
    _check_poisson("nu_journal", nu_journal)
    _check_poisson("nu_bearing", nu_bearing)
    sigma_i = (1.0 - nu_journal**2) / E_journal
    sigma_j = (1.0 - nu_bearing**2) / E_bearing
    r_eff = R_journal * R_bearing / (R_bearing - R_journal)
    return float(4.0 / (3.0 * (sigma_i + sigma_j)) * math.sqrt(r_eff))
