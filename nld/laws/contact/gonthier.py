"""Contact law ``gonthier``: Gonthier et al. (2004) force F = K delta^n + chi delta^n ddot, chi = (1 - cr^2) K / (cr v_minus) (N).

One file per law (docs/contact-laws.md, "Adding a contact law"): the force as a numba
function and ``LAW``, its entry in the registry (nld.laws.law).
"""
from __future__ import annotations

import numba

from nld.laws.law import ContactLaw


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


LAW = ContactLaw(
    name='gonthier',
    force=gonthier,
    extra=('restitution', 'v_minus'),
    reference='Gonthier, McPhee, Lange, Piedboeuf, Multibody Syst. Dyn. 11 (2004) 209-233',
)
