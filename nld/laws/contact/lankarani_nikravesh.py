"""Contact law ``lankarani_nikravesh``: Lankarani-Nikravesh (1990) force F = K delta^n (1 + 3(1 - cr^2)/4 * ddot/v_minus) (N).

One file per law (docs/contact-laws.md, "Adding a contact law"): the force as a numba
function and ``LAW``, its entry in the registry (nld.laws.law).
"""
from __future__ import annotations

import numba

from nld.laws.law import ContactLaw


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


LAW = ContactLaw(
    name='lankarani_nikravesh',
    force=lankarani_nikravesh,
    extra=('restitution', 'v_minus'),
    reference='Lankarani & Nikravesh, J. Mech. Des. 112 (1990) 369-376',
)
