"""Contact law ``flores``: Flores et al. (2011) force F = K delta^n + chi delta^n ddot, chi = 8(1 - cr) K / (5 cr v_minus) (N).

One file per law (docs/contact-laws.md, "Adding a contact law"): the force as a numba
function and ``LAW``, its entry in the registry (nld.laws.law).
"""
from __future__ import annotations

import numba

from nld.laws.law import ContactLaw


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


LAW = ContactLaw(
    name='flores',
    force=flores,
    extra=('restitution', 'v_minus'),
    reference='Flores, Machado, Silva, Martins, Multibody Syst. Dyn. 25 (2011) 357-375',
)
