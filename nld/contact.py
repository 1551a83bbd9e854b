"""Normal contact-force laws of a revolute joint with clearance (docs/contact-laws.md).

Every law is a scalar function of float64 arguments, compiled with numba and inlined into the
generated kernels, which import and call exactly these names:

* ``delta``  penetration depth (m), ``delta = |e| - c`` with ``e`` the journal-centre offset and
  ``c = R_bearing - R_journal`` the radial clearance; no contact when ``delta <= 0``;
* ``ddot``   penetration rate d(delta)/dt (m/s), positive while approaching (compression),
  negative while separating (restitution);
* ``K``      generalised stiffness (N/m^n; N/m^1.5 for the Hertz exponent n = 1.5);
* ``n``      force exponent (-), 1.5 for Hertz point contact;
* ``cr``     coefficient of restitution (-), 0 < cr <= 1;
* ``v_minus`` approach velocity at contact onset (m/s), > 0. The laws do not floor it: the caller
  stores ``max(ddot_at_onset, min_approach_velocity)`` so the division is always by a positive value.

Every law returns ``max(F, 0.0)``: the joint cannot pull (no adhesion), so a damping term that would
make the force negative late in restitution is clamped to zero. Every law returns 0 for
``delta <= 0``.

The seed paper (Zhang, Liu, Xu, Hou 2013, excavating system with two clearances, eqs 6-9)
writes ``F_n = K delta^1.5 + C v_n`` with K printed in N/m^2; with the exponent 1.5 the
consistent unit is N/m^1.5, which is what is used here.
"""
from __future__ import annotations

import math
import numbers

import numba


@numba.njit(cache=True, inline="always")
def hertz(delta, ddot, K, n):
    """Pure elastic Hertz force F = K delta^n (N); conservative, no dissipation.

    delta (m), ddot (m/s, unused, kept for a uniform signature), K (N/m^n), n (-).
    Hertz point-contact law as used by the seed paper (eqs 6, 8) without its damping term.
    Returns 0 for delta <= 0.
    """
    if delta <= 0.0:
        return 0.0
    f = K * delta**n
    return max(f, 0.0)


@numba.njit(cache=True, inline="always")
def hertz_damped(delta, ddot, K, n, C):
    """Hertz force with linear damping F = K delta^n + C ddot (N), seed paper eqs 6-9.

    delta (m), ddot (m/s, > 0 approaching), K (N/m^n; the seed prints N/m^2 but uses n = 1.5,
    so N/m^1.5), n (-), C (N s/m). The force jumps by C*ddot at contact onset when ddot != 0,
    as in the seed. Clamped at zero (no adhesive pull during restitution); 0 for delta <= 0.
    """
    if delta <= 0.0:
        return 0.0
    f = K * delta**n + C * ddot
    return max(f, 0.0)


@numba.njit(cache=True, inline="always")
def hertz_damped_contact(delta, ddot, K, n, C):
    """hertz_damped in a kernel's contact mode (N): F = max(K max(delta, 0)^n + C ddot, 0).

    Same units as ``hertz_damped``. The mode runs from the located onset (delta = 0) to the
    located clamp (K delta^n + C ddot = 0), so the only difference to ``hertz_damped`` is at
    delta <= 0: the damping term C ddot is kept. The onset state is delta = 0 only to the root
    tolerance, of either sign (|delta| ~ 1e-12 m measured); ``hertz_damped`` would give 0 there
    and C ddot0 a moment later, a jump of C ddot0 inside the first step after the onset, which
    DOPRI5's error estimate weighs with b1 - b1* = 35/384 - 5179/57600 (1.3 % of the error it
    makes: slider_crank at rtol 1e-8 had 280x LN's journal error, benchmarks/results/hybrid.md).
    """
    f = C * ddot
    if delta > 0.0:
        f += K * delta**n
    return max(f, 0.0)


@numba.njit(cache=True, inline="always")
def lankarani_nikravesh(delta, ddot, K, n, cr, v_minus):
    """Lankarani-Nikravesh (1990) force F = K delta^n (1 + 3(1 - cr^2)/4 * ddot/v_minus) (N).

    Hysteresis damping chi = 3(1 - cr^2) K / (4 v_minus), F = K delta^n + chi delta^n ddot.
    Lankarani H.M., Nikravesh P.E., J. Mech. Des. 112 (1990) 369-376. Accurate for cr near 1.
    delta (m), ddot (m/s, > 0 approaching), K (N/m^n), n (-), cr (-), v_minus (m/s, > 0; the
    caller floors it with min_approach_velocity). Clamped at zero (no adhesive pull during
    restitution); 0 for delta <= 0.
    """
    if delta <= 0.0:
        return 0.0
    dn = delta**n
    chi = 3.0 * (1.0 - cr * cr) * K / (4.0 * v_minus)
    f = K * dn + chi * dn * ddot
    return max(f, 0.0)


@numba.njit(cache=True, inline="always")
def hunt_crossley(delta, ddot, K, n, cr, v_minus):
    """Hunt-Crossley force F = K delta^n + chi delta^n ddot, chi = 3(1 - cr) K / (2 v_minus) (N).

    Hunt K.H., Crossley F.R.E., J. Appl. Mech. 42 (1975) 440-445 (chi as written in references
    section 4). delta (m), ddot (m/s, > 0 approaching), K (N/m^n), n (-), cr (-), v_minus (m/s,
    > 0, floored by the caller). Clamped at zero (no adhesive pull during restitution); 0 for
    delta <= 0.
    """
    if delta <= 0.0:
        return 0.0
    dn = delta**n
    chi = 3.0 * (1.0 - cr) * K / (2.0 * v_minus)
    f = K * dn + chi * dn * ddot
    return max(f, 0.0)


@numba.njit(cache=True, inline="always")
def flores(delta, ddot, K, n, cr, v_minus):
    """Flores et al. (2011) force F = K delta^n + chi delta^n ddot, chi = 8(1 - cr) K / (5 cr v_minus) (N).

    Flores P., Machado M., Silva M.T., Martins J.M., Multibody Syst. Dyn. 25 (2011) 357-375.
    Valid over the whole range 0 < cr <= 1 (better than Lankarani-Nikravesh for low cr).
    delta (m), ddot (m/s, > 0 approaching), K (N/m^n), n (-), cr (-, > 0), v_minus (m/s, > 0,
    floored by the caller). Clamped at zero (no adhesive pull during restitution); 0 for
    delta <= 0.
    """
    if delta <= 0.0:
        return 0.0
    dn = delta**n
    chi = 8.0 * (1.0 - cr) * K / (5.0 * cr * v_minus)
    f = K * dn + chi * dn * ddot
    return max(f, 0.0)


@numba.njit(cache=True, inline="always")
def gonthier(delta, ddot, K, n, cr, v_minus):
    """Gonthier et al. (2004) force F = K delta^n + chi delta^n ddot, chi = (1 - cr^2) K / (cr v_minus) (N).

    Gonthier Y., McPhee J., Lange C., Piedboeuf J.-C., Multibody Syst. Dyn. 11 (2004) 209-233.
    delta (m), ddot (m/s, > 0 approaching), K (N/m^n), n (-), cr (-, > 0), v_minus (m/s, > 0,
    floored by the caller). Clamped at zero (no adhesive pull during restitution); 0 for
    delta <= 0.
    """
    if delta <= 0.0:
        return 0.0
    dn = delta**n
    chi = (1.0 - cr * cr) * K / (cr * v_minus)
    f = K * dn + chi * dn * ddot
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
