"""Contact law ``hertz_damped``: Hertz force with linear damping F = K delta^n + C ddot (N), seed paper eqs 6-9.

One file per law (docs/contact-laws.md, "Adding a contact law"): the force as a numba
function and ``LAW``, its entry in the registry (nld.laws.law).
"""
from __future__ import annotations

import numba

from nld.laws.law import ContactLaw


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
def hertz_damped_unclamped(delta, ddot, K, n, C):
    """K delta^n + C ddot (N) for delta >= 0, without the clamp at zero: its zero during
    restitution is the located clamp event (the force's kink), docs/contact-laws.md "Modes"."""
    return K * max(delta, 0.0)**n + C * ddot


LAW = ContactLaw(
    name='hertz_damped',
    force=hertz_damped,
    extra=('damping',),
    jump_at_onset=True,
    unclamped=hertz_damped_unclamped,
    reference='Zhang, Liu, Xu, Hou (2013), eqs 6-9 (seed paper)',
)
