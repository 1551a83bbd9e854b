"""Tangential (friction) force laws of a revolute joint with clearance (docs/contact-laws.md).

Sign convention: every law returns F_t (N) signed ALONG the slip velocity v_t (m/s), as in the
seed paper (Zhang, Liu, Xu, Hou 2013, eqs 7, 9-11: F_t = f sigma F_n + C_t v_t). The caller applies
it opposite to the slip, i.e. on the journal the friction force is ``-F_t * t`` where ``t`` is the
unit tangent used by :func:`slip_velocity`, and ``+F_t * t`` on the bearing.

Every law is a scalar numba function inlined into the generated kernels, which import and call
exactly these names.
"""
from __future__ import annotations

import numba


@numba.njit(cache=True, inline="always")
def coulomb(vt, Fn, mu):
    """Coulomb friction F_t = mu Fn sigma (N), sigma = +1 if vt >= 0 else -1.

    Seed paper eqs 7, 10-11 (friction part of F_t). vt slip velocity (m/s), Fn normal force (N,
    >= 0), mu friction coefficient (-). Note the seed's convention sigma(0) = +1: at vt == 0 the
    law returns +mu Fn, not 0 (discontinuous; prefer ``ambrosio`` for integration).
    """
    sigma = 1.0 if vt >= 0.0 else -1.0
    return mu * Fn * sigma


@numba.njit(cache=True, inline="always")
def ambrosio(vt, Fn, mu, v0, v1):
    """Modified Coulomb friction F_t = mu c_d(|vt|) Fn sign(vt) (N) (Ambrosio 2003).

    c_d = 0 for |vt| <= v0, (|vt| - v0)/(v1 - v0) for v0 < |vt| < v1, 1 for |vt| >= v1: a
    continuous regularisation without stiction. Ambrosio J.A.C., "Impact of rigid and flexible
    multibody systems: deformation description and contact models", Virtual Nonlinear Multibody
    Systems, NATO Sci. Ser. II 103 (2003) 57-81; used by Flores et al. (2006) for clearance joints.
    vt slip velocity (m/s), Fn normal force (N, >= 0), mu (-), v0 < v1 tolerance velocities
    (m/s, >= 0). c_d uses |vt| (a bug seen in public code uses the signed vt, which makes friction
    vanish for negative slip). Never divides by zero: the ramp branch implies v1 > |vt| > v0.
    """
    s = abs(vt)
    if s <= v0:
        return 0.0
    if s >= v1:
        cd = 1.0
    else:
        cd = (s - v0) / (v1 - v0)
    sigma = 1.0 if vt >= 0.0 else -1.0
    return mu * cd * Fn * sigma


@numba.njit(cache=True, inline="always")
def viscous(vt, Ct):
    """Viscous tangential force F_t = Ct vt (N), the seed paper's C_t v_t term (eqs 7, 9).

    vt slip velocity (m/s), Ct tangential damping coefficient (N s/m).
    """
    return Ct * vt


@numba.njit(cache=True, inline="always")
def slip_velocity(dex, dey, nx, ny, w_journal, w_bearing, R_journal, R_bearing):
    """Slip velocity v_t (m/s) of the journal's contact point relative to the bearing's.

    With e = journal centre - bearing centre, n = e/|e| = (nx, ny) and t = (-ny, nx):
    v_t = (dex, dey) . t + w_journal R_journal - w_bearing R_bearing.
    dex, dey = de/dt (m/s), w_journal, w_bearing angular velocities (rad/s), radii (m).
    Seed paper eq. 5 writes v_t = de_y cos(a) - de_x sin(a) + (theta_i' - theta_{i+1}') R_i with
    n = (cos a, sin a), i.e. with equal radii R_journal = R_bearing = R_i; the general form here
    uses each body's own radius (the contact point lies at R_journal n from the journal centre and
    at R_bearing n from the bearing centre).
    """
    return -dex * ny + dey * nx + w_journal * R_journal - w_bearing * R_bearing
