"""Why a mechanism cannot be assembled, decided from its geometry.

When Newton-Raphson finds no configuration that closes every joint at the start, the residual of
its last (failed) iterate says nothing reliable: which joint carries the largest residual of a
diverging iteration depends on the rounding of the linear solves (it changes with the BLAS kernel
the CPU selects). The diagnosis here uses only the scene's geometry.

The bodies whose pose is known before any solve are *fixed*: the ground, and the driven crank
(its angle is the driver angle, its joint point on the ground point). Every other body is free.
Following the joints from a fixed body through free bodies that have exactly two joints each
gives a *chain* F0 - b1 - ... - bk - F1 between two fixed bodies. A chain of revolute joints
connects the fixed point P (its first joint on F0) to the fixed point Q (its last joint on F1)
iff their distance d lies in the reach of a planar serial chain of links of pin-to-pin lengths
L1..Lk, the annulus

    max(0, 2 max L - sum L) <= d <= sum L

(the classical workspace of a planar open chain, e.g. Kumar & Waldron 1981, J. Mech. Des. 103;
for two links it is Grashof's triangle inequality). A chain whose last joint is a prismatic joint
with a fixed body ends on a line (the slider's angle is fixed by the joint, so the point of its
other joint slides on a shifted copy of the guide); the links then reach it iff sum L >= the
distance h from P to that line. The *gap* is how far d (or h) lies outside the reach (m).

Chains through a body with three or more joints, or with a prismatic joint between two free
bodies, are not decided here (``diagnose`` returns None for them when no simple chain fails);
the caller then says only that no configuration was found.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Closure", "diagnose"]

_REL_TOL = 1e-9       # a chain within this fraction of its reach closes (a dead-centre start)


@dataclass(frozen=True)
class Closure:
    """A loop that cannot close: its joints (the named joint first), bodies, the joint named as the
    place where it opens, the gap (m) and the reason in words."""
    loop: list
    bodies: list
    joint: str
    gap: float
    reason: str


def _rot(th: float, s) -> np.ndarray:
    c, sn = math.cos(th), math.sin(th)
    return np.array([c * s[0] - sn * s[1], sn * s[0] + c * s[1]])


def _fixed_poses(mdl, t: float) -> dict:
    """Poses (x, y, theta) of the fixed bodies by name: the ground and the driven crank."""
    sc = mdl.scene
    fixed = {"ground": (0.0, 0.0, 0.0)}
    if mdl.crank is not None:
        dj = sc.joints[sc.driver.joint]
        crank = mdl.names[mdl.crank]
        k = 0 if dj.bodies[0] == crank else 1
        th = float(mdl.driver_angle(t))
        g = np.asarray(sc.ground_points[dj.points[1 - k]], float)
        s = np.asarray(sc.bodies[crank].points[dj.points[k]], float)
        r = g - _rot(th, s)
        fixed[crank] = (float(r[0]), float(r[1]), th)
    return fixed


def _local(sc, body: str, pname: str) -> np.ndarray:
    pts = sc.ground_points if body == "ground" else sc.bodies[body].points
    return np.asarray(pts[pname], float)


def _world(sc, fixed, body: str, pname: str) -> np.ndarray:
    x, y, th = fixed[body]
    return np.array([x, y]) + _rot(th, _local(sc, body, pname))


def _point_of(j, body: str) -> str:
    """The joint's point name on ``body``."""
    return j.points[0] if j.bodies[0] == body else j.points[1]


def _chains(sc, fixed):
    """The chains F0 - b1 - ... - bk - F1, as (F0, [(joint, body entered)...], F1) in a
    deterministic order (scene joint order), each once; chains through a body with more than two
    joints are left out."""
    joints_of: dict = {}
    for jn, j in sc.joints.items():
        for b in set(j.bodies):
            joints_of.setdefault(b, []).append(jn)
    seen, out = set(), []
    for jn, j in sc.joints.items():
        for start in j.bodies:
            other = j.bodies[1] if j.bodies[0] == start else j.bodies[0]
            if start not in fixed or other in fixed:
                continue
            steps, body, via, ok = [], other, jn, True
            steps.append((jn, body))
            while body not in fixed:
                js = joints_of.get(body, [])
                if len(js) != 2:
                    ok = False
                    break
                via = js[0] if js[1] == via else js[1]
                vj = sc.joints[via]
                body = vj.bodies[1] if vj.bodies[0] == body else vj.bodies[0]
                steps.append((via, body))
                if len(steps) > len(sc.joints):
                    ok = False
                    break
            key = frozenset(s[0] for s in steps)
            if ok and key not in seen:
                seen.add(key)
                out.append((start, steps))
    return out


def _chain_closure(mdl, sc, fixed, f0, steps):
    """(gap, reason, named joint) of a chain that cannot close, None if it can or is not decided."""
    types = [sc.joints[jn].type for jn, _ in steps]
    if any(tp != "revolute" for tp in types[1:-1]):
        return None
    if types[0] != "revolute":
        if types[-1] != "revolute":
            return None
        # walk it the other way: the prismatic joint last
        bodies = [f0] + [b for _, b in steps]
        bodies = bodies[::-1]
        jns = [jn for jn, _ in steps][::-1]
        f0 = bodies[0]
        steps = list(zip(jns, bodies[1:]))
        types = types[::-1]
    f1 = steps[-1][1]
    free = [b for _, b in steps[:-1]]                 # b1 .. bk
    jns = [jn for jn, _ in steps]                     # j1 .. j(k+1)
    j1 = sc.joints[jns[0]]
    p_name = _point_of(j1, f0)
    P = _world(sc, fixed, f0, p_name)
    prismatic_end = types[-1] != "revolute"
    links = free[:-1] if prismatic_end else free      # bodies whose pin-to-pin length counts
    lengths = []
    for i, b in enumerate(links):
        a = _local(sc, b, _point_of(sc.joints[jns[i]], b))
        c = _local(sc, b, _point_of(sc.joints[jns[i + 1]], b))
        lengths.append(float(np.hypot(*(c - a))))
    total = float(sum(lengths))
    span = " + ".join(f"{b} {L:.4g} m" for b, L in zip(links, lengths))
    if not prismatic_end:
        jl = sc.joints[jns[-1]]
        q_name = _point_of(jl, f1)
        d = float(np.hypot(*(_world(sc, fixed, f1, q_name) - P)))
        rmin = max(0.0, 2.0 * max(lengths) - total) if lengths else 0.0
        scale = max(d, total, 1e-300)
        ends = f"point {p_name} of {f0} and point {q_name} of {f1}"
        if d > total + _REL_TOL * scale:
            return (d - total, f"{ends} are {d:.4g} m apart but the links between them "
                               f"({span}) reach at most {total:.4g} m", None)
        if d < rmin - _REL_TOL * scale:
            return (rmin - d, f"{ends} are {d:.4g} m apart but the links between them "
                              f"({span}) cannot come closer than {rmin:.4g} m", None)
        return None
    # last joint prismatic between bk (free) and f1 (fixed): bk's angle is fixed by the joint
    jp = sc.joints[jns[-1]]
    bk = free[-1]
    thf = fixed[f1][2]
    pri = mdl.pri_names.index(jns[-1])
    th0 = float(mdl.pth0[pri])                         # theta(bodies[1]) - theta(bodies[0])
    axis = np.asarray(jp.axis, float) / math.hypot(*jp.axis)
    c_local = _local(sc, bk, _point_of(sc.joints[jns[-2]], bk))
    if jp.bodies[0] == f1:                             # the guide on the fixed body
        thk = thf + th0
        base = _world(sc, fixed, f1, jp.points[0])
        u = _rot(thf, axis)
        base = base + _rot(thk, c_local - _local(sc, bk, jp.points[1]))
    else:                                              # the guide on the sliding free body
        thk = thf - th0
        base = _world(sc, fixed, f1, jp.points[1])
        u = _rot(thk, axis)
        base = base + _rot(thk, c_local - _local(sc, bk, jp.points[0]))
    w = P - base
    h = float(abs(w[0] * u[1] - w[1] * u[0]))         # distance from P to the line base + s u
    scale = max(h, total, 1e-300)
    if h > total + _REL_TOL * scale:
        c_name = _point_of(sc.joints[jns[-2]], bk)
        links_txt = f"the links between them ({span}) reach at most {total:.4g} m" if links \
            else "no link lies between them"
        return (h - total, f"point {c_name} of {bk}, which slides on the guide of joint {jns[-1]}, "
                           f"stays {h:.4g} m from point {p_name} of {f0} but {links_txt}", None)
    return None


def diagnose(mdl, t: float = 0.0):
    """The first loop (in the scene's joint order) that cannot close at time t, from its geometry
    alone, as a :class:`Closure`; None when no simple chain is found that cannot close.

    ``mdl``: the nld.model.ideal._Model of the scene. Deterministic: it does not depend on any
    iterate, so not on rounding."""
    sc = mdl.scene
    fixed = _fixed_poses(mdl, t)
    # two fixed bodies joined by a further joint (besides the driver's)
    drv = sc.driver.joint if sc.driver is not None else None
    for jn, j in sc.joints.items():
        if jn == drv or j.bodies[0] not in fixed or j.bodies[1] not in fixed or j.type != "revolute":
            continue
        a = _world(sc, fixed, j.bodies[0], j.points[0])
        b = _world(sc, fixed, j.bodies[1], j.points[1])
        gap = float(np.hypot(*(a - b)))
        if gap > _REL_TOL * max(float(np.hypot(*a)), float(np.hypot(*b)), 1e-300):
            return Closure([jn] + ([drv] if drv else []), list(j.bodies), jn, gap,
                           f"its points are {gap:.4g} m apart on two bodies that do not move")
    for f0, steps in _chains(sc, fixed):
        found = _chain_closure(mdl, sc, fixed, f0, steps)
        if found is None:
            continue
        gap, reason, _ = found
        jns = [jn for jn, _ in steps]
        f1 = steps[-1][1]
        if f0 != f1 and drv is not None:
            jns = jns + [drv]                          # through the crank's joint with the ground
        free = {b for _, b in steps[:-1]}
        # the named joint: a clearance joint of the loop, else a joint between two free bodies
        inner = [jn for jn in sc.joints if jn in jns and set(sc.joints[jn].bodies) <= free]
        clear = [jn for jn in sc.joints if jn in jns and sc.joints[jn].has_clearance]
        name = (clear or inner or [jns[0]])[0]
        k = jns.index(name)
        loop = jns[k:] + jns[:k]
        bodies = []
        for jn in loop:
            for b in sc.joints[jn].bodies:
                if b not in bodies:
                    bodies.append(b)
        return Closure(loop, bodies, name, gap, reason)
    return None
