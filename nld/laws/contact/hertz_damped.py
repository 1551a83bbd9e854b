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
    """K delta^n + C ddot (N) for delta >= 0, without the clamp at zero: the seed paper's force
    (Zhang, Liu, Xu, Hou 2013, eqs 6-9) before ``max(., 0)``. delta (m, negative taken as 0), ddot
    (m/s), K (N/m^n), n (-), C (N s/m). Its zero during restitution is the located clamp event
    (the force's kink), docs/contact-laws.md "Modes"."""
    return K * max(delta, 0.0)**n + C * ddot


@numba.njit(cache=True, inline="always")
def hertz_damped_contact(delta, ddot, K, n, C):
    """hertz_damped in a kernel's contact mode (N): F = K max(delta, 0)^n + C ddot, not clamped.
    The seed paper's force (Zhang et al. 2013, eqs 6-9); delta (m), ddot (m/s), K (N/m^n), n (-),
    C (N s/m), as ``hertz_damped``. The mode runs from the located onset (delta = 0) to the
    located clamp (K delta^n + C ddot = 0, after which the clamped mode has F = 0), so on the
    accepted trajectory F >= 0 and this equals ``hertz_damped`` for delta > 0. It differs in two
    places that only trial points of a step see:

    * at delta <= 0 the damping term C ddot is kept. The onset state is delta = 0 only to the
      root tolerance, of either sign (|delta| ~ 1e-12 m measured); ``hertz_damped`` would give 0
      there and C ddot0 a moment later, a jump of C ddot0 inside the first step after the onset,
      which DOPRI5's error estimate weighs with b1 - b1* = 35/384 - 5179/57600 (1.3 % of the
      error it makes: slider_crank at rtol 1e-8 had 280x LN's journal error,
      benchmarks/results/hybrid.md);
    * past the clamp, F < 0 is not cut to zero: max(F, 0) put a kink inside every step that
      crossed the clamp, which DOP853 rejected 4-7 times until a step ended just past it; the
      smooth extension lets the step through and the clamp event cuts it at the root.
    """
    f = C * ddot
    if delta > 0.0:
        f += K * delta**n
    return f


LAW = ContactLaw(
    name='hertz_damped',
    force=hertz_damped,
    extra=('damping',),
    jump_at_onset=True,
    unclamped=hertz_damped_unclamped,
    mode_force=hertz_damped_contact,
    reference='Zhang, Liu, Xu, Hou (2013), eqs 6-9 (seed paper)',
)
