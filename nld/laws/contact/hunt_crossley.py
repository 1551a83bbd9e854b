"""Contact law ``hunt_crossley``: Hunt-Crossley force F = K delta^n + chi delta^n ddot, chi = 3(1 - cr) K / (2 v_minus) (N).

One file per law (docs/contact-laws.md, "Adding a contact law"): the force as a numba
function and ``LAW``, its entry in the registry (nld.laws.law).
"""
from __future__ import annotations

import numba

from nld.laws.law import ContactLaw


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


LAW = ContactLaw(
    name='hunt_crossley',
    force=hunt_crossley,
    extra=('restitution', 'v_minus'),
    reference='Hunt & Crossley, J. Appl. Mech. 42 (1975) 440-445',
)
