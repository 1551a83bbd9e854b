"""Contact law ``hertz``: Pure elastic Hertz force F = K delta^n (N); conservative, no dissipation.

One file per law (docs/contact-laws.md, "Adding a contact law"): the force as a numba
function and ``LAW``, its entry in the registry (nld.laws.law).
"""
from __future__ import annotations

import numba

from nld.laws.law import ContactLaw


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


LAW = ContactLaw(
    name='hertz',
    force=hertz,
    extra=(),
    conservative=True,
    reference='Hertz point contact; seed paper (Zhang et al. 2013) eqs 6, 8 without damping',
)
