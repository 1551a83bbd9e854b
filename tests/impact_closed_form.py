"""Closed form of the impact oscillator's periodic orbits (nld.systems.impact), independent of nld's
integrators: exact linear segments (matrix exponential plus the harmonic particular solution),
contact times by Brent's method on the closed-form x(t), the monodromy as the product of the
segments' exponentials and the textbook saltation matrices S = I + (f+ - f-) n^T / (n^T f-)
(di Bernardo et al. 2008, sec. 2.5; Leine & Nijmeijer 2004, sec. 7) at x = d, n = (1, 0)."""
from __future__ import annotations

import math

import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq, fsolve


def _segment(p, contact, t0, x0):
    zeta, om, F, d, k, c = p
    A = (np.array([[0.0, 1.0], [-(1.0 + k), -(2.0 * zeta + c)]]) if contact
         else np.array([[0.0, 1.0], [-1.0, -2.0 * zeta]]))
    const = k * d if contact else 0.0
    X = np.linalg.solve(1j * om * np.eye(2) - A, np.array([0.0, F]))
    xc = -np.linalg.solve(A, np.array([0.0, const]))

    def xp(t):
        return (X * np.exp(1j * om * t)).real + xc

    def x(t):
        return xp(t) + expm(A * (t - t0)) @ (x0 - xp(t0))
    return A, x


def flow(p, x0, t_end, t0=0.0):
    """(x(t_end), monodromy, onsets, smallest approach speed at an onset) from x0 at t0."""
    zeta, om, F, d, k, c = p
    t, x = t0, np.array(x0, dtype=float)
    contact = x[0] > d
    M = np.eye(2)
    onsets, vmin = 0, math.inf
    while True:
        A, f = _segment(p, contact, t, x)
        grid = np.linspace(t, t_end, 1601)[1:]
        prev, gp, hit = t, x[0] - d, None
        for tt in grid:
            g = f(tt)[0] - d
            if (gp < 0.0 <= g) if not contact else (gp > 0.0 >= g):
                hit = brentq(lambda s: f(s)[0] - d, prev, tt, xtol=1e-15, rtol=1e-15)
                break
            prev, gp = tt, g
        if hit is None:
            return f(t_end), expm(A * (t_end - t)) @ M, onsets, vmin
        xe = f(hit)
        M = expm(A * (hit - t)) @ M
        v = xe[1]
        # f+ - f- = (0, -c v) at an onset, (0, +c v) at a separation; n^T f- = v
        M = (np.array([[1.0, 0.0], [-c, 1.0]]) if not contact
             else np.array([[1.0, 0.0], [c, 1.0]])) @ M
        if not contact:
            onsets += 1
            vmin = min(vmin, abs(v))
        t, x, contact = hit, xe, not contact


def periodic_orbit(p, guess, periods: int = 1):
    """(x*, monodromy, onsets per period, smallest approach speed) of the period-``periods``
    orbit near ``guess`` (scipy's fsolve on the closed-form map)."""
    T = 2.0 * math.pi / p[1] * periods
    x = fsolve(lambda x: flow(p, x, T)[0] - x, guess, xtol=1e-14)
    _, M, n, v = flow(p, x, T)
    return x, M, n, v
