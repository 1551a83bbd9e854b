"""Ideal-joint reference solution of a scene in absolute coordinates.

Every body has the coordinates (x, y, theta) of its centre of mass; every joint is treated as
ideal (a clearance joint is closed: journal centre = bearing centre). This is the classical
absolute-coordinate formulation of Nikravesh, *Computer-Aided Analysis of Mechanical Systems*
(1988): position analysis by Newton-Raphson on the constraint equations Phi(q, t) = 0,
velocity analysis Phi_q qd = -Phi_t, acceleration analysis Phi_q qdd = gamma, and inverse
dynamics M qdd - Phi_q^T lambda = Q_applied for the Lagrange multipliers, from which the joint
reactions and the driver torque are read. The formulation, the constraint equations, the gamma
terms and the sign conventions are written out in docs/ideal-reference.md.

Public functions: :func:`assemble`, :func:`ideal_solution`, :func:`loop_closure_error`.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from nld.errors import AssemblyError, SceneError, SolveError
from nld.model.scene_model import Scene

__all__ = ["assemble", "ideal_solution", "loop_closure_error", "POSITION_TOL", "MAX_NEWTON_ITER"]

POSITION_TOL = 1e-13        # m: Newton-Raphson tolerance on the constraint residual
MAX_NEWTON_ITER = 50
_COND_MAX = 1e12            # a constraint Jacobian with a larger condition number is singular
_EPS = np.finfo(float).eps
TWO_PI = 2.0 * np.pi


def _cross(a, b):
    """z component of a x b for arrays [..., 2]."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _perp(a):
    """R a with R the rotation by +90 degrees: (x, y) -> (-y, x)."""
    return np.stack((-a[..., 1], a[..., 0]), axis=-1)


def _rotate(theta, s):
    """A(theta) s for theta [N, K] and body-frame vectors s [K, 2] -> [N, K, 2]."""
    c, sn = np.cos(theta), np.sin(theta)
    return np.stack((c * s[:, 0] - sn * s[:, 1], sn * s[:, 0] + c * s[:, 1]), axis=-1)


class _Model:
    """The scene compiled into index arrays for the batched constraint kernels.

    Coordinates are kept "extended": q has shape [N, nb + 1, 3] where the last row is the ground
    (x = y = theta = 0 for all times), so that ground points need no special case; ground point
    coordinates are global, which is exactly A(0) s + 0. The Jacobian is built with the ground
    columns and they are dropped at the end.

    Constraint rows, in this order: two rows (x, y) per revolute joint, one "normal" row per
    prismatic joint, one "angle" row per prismatic joint, one driver row (if there is a driver).
    """

    def __init__(self, scene: Scene):
        self.scene = scene
        self.names = list(scene.bodies)
        self.nb = nb = len(self.names)
        if nb == 0:
            raise SceneError("bodies", {}, "a scene needs at least one body")
        self.g = nb                              # index of the ground row
        idx = {n: k for k, n in enumerate(self.names)}
        idx["ground"] = nb
        self.idx = idx
        self.mass = np.array([b.mass for b in scene.bodies.values()], float)
        self.inertia = np.array([b.inertia for b in scene.bodies.values()], float)
        self.n = 3 * nb

        def point(body: str, pname: str, path: str) -> tuple[float, float]:
            if body not in idx:
                raise SceneError(path, body, "must name a body or 'ground'")
            pts = scene.ground_points if body == "ground" else scene.bodies[body].points
            if pname not in pts:
                raise SceneError(path, pname, f"must name a point of {body} ({', '.join(pts)})")
            p = pts[pname]
            return float(p[0]), float(p[1])

        # crank / driver
        drv = scene.driver
        self.crank = None
        if drv is not None:
            if drv.joint not in scene.joints:
                raise SceneError("driver.joint", drv.joint, "must name a joint")
            dj = scene.joints[drv.joint]
            if dj.type != "revolute" or "ground" not in dj.bodies or dj.bodies[0] == dj.bodies[1]:
                raise SceneError("driver.joint", drv.joint, "must be a revolute joint between the ground and a body")
            self.crank = idx[dj.bodies[1] if dj.bodies[0] == "ground" else dj.bodies[0]]
            self.drv_angle0 = float(drv.angle0)
            self.drv_speed = float(drv.speed)
            self.drv_mode = drv.mode

        # angle hints (the crank's hint is the driver angle at t = 0)
        self.hint = np.array([b.angle0 for b in scene.bodies.values()] + [0.0], float)
        if self.crank is not None:
            self.hint[self.crank] = self.drv_angle0

        rev, pri = [], []
        for jn, j in scene.joints.items():
            bi, bj = j.bodies
            if bi == bj:
                raise SceneError(f"joints.{jn}.bodies", list(j.bodies), "must name two different bodies")
            si = point(bi, j.points[0], f"joints.{jn}.points")
            sj = point(bj, j.points[1], f"joints.{jn}.points")
            if j.type == "revolute":
                rev.append((jn, idx[bi], idx[bj], si, sj))
            elif j.type == "prismatic":
                u = np.asarray(j.axis, float)
                nu = float(np.hypot(*u))
                if not nu > 0:
                    raise SceneError(f"joints.{jn}.axis", list(j.axis), "must be a non-zero vector")
                u = u / nu
                v = (-u[1], u[0])
                th0 = self.hint[idx[bj]] - self.hint[idx[bi]]
                pri.append((jn, idx[bi], idx[bj], si, sj, v, th0))
            else:
                raise SceneError(f"joints.{jn}.type", j.type, "must be 'revolute' or 'prismatic'")
        self.rev_names = [r[0] for r in rev]
        self.pri_names = [p[0] for p in pri]
        K, P = len(rev), len(pri)
        self.K, self.P = K, P
        self.ri = np.array([r[1] for r in rev], int)
        self.rj = np.array([r[2] for r in rev], int)
        self.rsi = np.array([r[3] for r in rev], float).reshape(K, 2)
        self.rsj = np.array([r[4] for r in rev], float).reshape(K, 2)
        self.pi = np.array([p[1] for p in pri], int)
        self.pj = np.array([p[2] for p in pri], int)
        self.psi = np.array([p[3] for p in pri], float).reshape(P, 2)
        self.psj = np.array([p[4] for p in pri], float).reshape(P, 2)
        self.pv = np.array([p[5] for p in pri], float).reshape(P, 2)
        self.pth0 = np.array([p[6] for p in pri], float)
        self.vs_i = np.einsum("pk,pk->p", self.pv, self.psi)      # v . s_i (constant)

        self.row_rev = 0
        self.row_pn = 2 * K
        self.row_pa = 2 * K + P
        self.row_drv = 2 * K + 2 * P
        self.m = self.row_drv + (1 if self.crank is not None else 0)
        # rows measured in rad (tolerance scaled with the angle magnitude)
        self.angle_rows = np.zeros(self.m, bool)
        self.angle_rows[self.row_pa:] = True

        # Jacobian template with the constant entries; index arrays of the variable ones
        ne = 3 * (nb + 1)
        J0 = np.zeros((self.m, ne))
        kr = np.arange(K)
        r0, r1 = 2 * kr, 2 * kr + 1
        J0[r0, 3 * self.ri] = 1.0
        J0[r1, 3 * self.ri + 1] = 1.0
        J0[r0, 3 * self.rj] = -1.0
        J0[r1, 3 * self.rj + 1] = -1.0
        pa = self.row_pa + np.arange(P)
        J0[pa, 3 * self.pi + 2] = -1.0
        J0[pa, 3 * self.pj + 2] = 1.0
        if self.crank is not None:
            J0[self.row_drv, 3 * self.crank + 2] = 1.0
        self.J0 = J0
        self.rev_r0, self.rev_r1 = r0, r1
        self.pn_rows = self.row_pn + np.arange(P)
        # gathered rotations of _geometry: (body, body-frame vector) pairs
        self.gidx = np.concatenate((self.ri, self.rj, self.pi, self.pj)).astype(int)
        self.gs = np.concatenate((self.rsi, self.rsj, self.pv, self.psj)).reshape(-1, 2)
        # flat positions (row * ne + col) of the variable Jacobian entries, in the order of jac()
        ci, cj = 3 * self.ri + 2, 3 * self.rj + 2
        pn = self.pn_rows
        pi3, pj3 = 3 * self.pi, 3 * self.pj
        self.jflat = np.concatenate((r0 * ne + ci, r1 * ne + ci, r0 * ne + cj, r1 * ne + cj,
                                     pn * ne + pi3, pn * ne + pi3 + 1, pn * ne + pi3 + 2,
                                     pn * ne + pj3, pn * ne + pj3 + 1, pn * ne + pj3 + 2)).astype(int)

    # ------------------------------------------------------------------ kinematics kernels
    def extend(self, q):
        """[N, nb, 3] -> [N, nb + 1, 3] with the ground row (zeros) appended."""
        q = np.asarray(q, float)
        return np.concatenate((q, np.zeros((q.shape[0], 1, 3))), axis=1)

    def _geometry(self, qe):
        """Rotated joint vectors: a_i = A_i s_i, a_j = A_j s_j (revolute joints), the guide normal
        n = A_i v, b_j = A_j s_j of the sliding point and e = r_j - r_i + b_j (prismatic joints)."""
        th = qe[:, :, 2]
        c = np.cos(th)[:, self.gidx]
        s = np.sin(th)[:, self.gidx]
        out = np.empty(c.shape + (2,))
        out[..., 0] = c * self.gs[:, 0] - s * self.gs[:, 1]
        out[..., 1] = s * self.gs[:, 0] + c * self.gs[:, 1]
        K, P = self.K, self.P
        ai, aj = out[:, :K], out[:, K:2 * K]
        n, bj = out[:, 2 * K:2 * K + P], out[:, 2 * K + P:]
        e = qe[:, self.pj, :2] - qe[:, self.pi, :2] + bj
        return ai, aj, n, bj, e

    def phi(self, qe, t, geo=None):
        """Constraint residuals [N, m] at times t [N]."""
        ai, aj, n, bj, e = self._geometry(qe) if geo is None else geo
        N = qe.shape[0]
        out = np.empty((N, self.m))
        d = qe[:, self.ri, :2] + ai - qe[:, self.rj, :2] - aj
        out[:, self.rev_r0] = d[..., 0]
        out[:, self.rev_r1] = d[..., 1]
        out[:, self.pn_rows] = n[..., 0] * e[..., 0] + n[..., 1] * e[..., 1] - self.vs_i
        out[:, self.row_pa:self.row_drv] = qe[:, self.pj, 2] - qe[:, self.pi, 2] - self.pth0
        if self.crank is not None:
            out[:, self.row_drv] = qe[:, self.crank, 2] - self.driver_angle(t)
        return out

    def driver_angle(self, t):
        return self.drv_angle0 + self.drv_speed * np.asarray(t, float)

    def phi_t(self):
        """Phi_t [m] (constant in time: only the driver row depends on t)."""
        out = np.zeros(self.m)
        if self.crank is not None:
            out[self.row_drv] = -self.drv_speed
        return out

    def jac(self, qe, geo=None):
        """Constraint Jacobian Phi_q [N, m, 3 nb] (ground columns dropped)."""
        ai, aj, n, bj, e = self._geometry(qe) if geo is None else geo
        N = qe.shape[0]
        J = np.empty((N,) + self.J0.shape)
        J[:] = self.J0
        vals = np.concatenate((-ai[..., 1], ai[..., 0], aj[..., 1], -aj[..., 0],
                               -n[..., 0], -n[..., 1], _cross(n, e), n[..., 0], n[..., 1],
                               _cross(bj, n)), axis=1)
        J.reshape(N, -1)[:, self.jflat] = vals
        return J[:, :, : self.n]

    def gamma(self, qe, qde, geo=None):
        """Right-hand side of the acceleration equations Phi_q qdd = gamma, [N, m]."""
        ai, aj, n, bj, e = self._geometry(qe) if geo is None else geo
        N = qe.shape[0]
        w = qde[:, :, 2]
        out = np.zeros((N, self.m))
        wi, wj = w[:, self.ri, None], w[:, self.rj, None]
        gr = ai * wi**2 - aj * wj**2
        out[:, self.rev_r0] = gr[..., 0]
        out[:, self.rev_r1] = gr[..., 1]
        wi, wj = w[:, self.pi], w[:, self.pj]
        edot = qde[:, self.pj, :2] - qde[:, self.pi, :2] + _perp(bj) * wj[..., None]
        out[:, self.pn_rows] = (wi**2 * np.einsum("npk,npk->np", n, e)
                                - 2.0 * wi * np.einsum("npk,npk->np", _perp(n), edot)
                                + wj**2 * np.einsum("npk,npk->np", n, bj))
        return out

    # ------------------------------------------------------------------ assembly guess
    def initial_guess(self, t: float) -> np.ndarray:
        """Bodies placed along the joints from the ground with the angle hints.

        Revolute joints are used first (the body's joint point is put on the placed body's
        joint point); a body reachable only through a prismatic joint gets its sliding point
        on the guide point. A body not connected to the ground keeps its hint angle at the origin.
        """
        th = self.hint.copy()
        if self.crank is not None:
            th[self.crank] = float(self.driver_angle(t))
        q = np.zeros((self.nb + 1, 3))
        q[:, 2] = th
        q[self.g] = 0.0
        placed = {self.g}

        def gpoint(b, s):
            c, sn = np.cos(q[b, 2]), np.sin(q[b, 2])
            return q[b, :2] + np.array([c * s[0] - sn * s[1], sn * s[0] + c * s[1]])

        def local(b, s):
            c, sn = np.cos(q[b, 2]), np.sin(q[b, 2])
            return np.array([c * s[0] - sn * s[1], sn * s[0] + c * s[1]])

        links = [(self.ri[k], self.rj[k], self.rsi[k], self.rsj[k]) for k in range(self.K)]
        plinks = [(self.pi[k], self.pj[k], self.psi[k], self.psj[k]) for k in range(self.P)]
        while True:
            progress = False
            for group in (links, plinks):
                for i, j, si, sj in group:
                    if i in placed and j not in placed:
                        q[j, :2] = gpoint(i, si) - local(j, sj)
                        placed.add(j)
                        progress = True
                    elif j in placed and i not in placed:
                        q[i, :2] = gpoint(j, sj) - local(i, si)
                        placed.add(i)
                        progress = True
                if progress:
                    break           # revolute joints first, again
            if not progress:
                break
        return q[: self.nb]

    # ------------------------------------------------------------------ solvers
    def tolerance(self, qe, t):
        """Per-row tolerance: POSITION_TOL (m) for geometric rows; angle rows get at least a few
        ulps of the angles involved (a crank angle of 500 rad is only known to ~1e-13 rad)."""
        tol = np.full((qe.shape[0], self.m), POSITION_TOL)
        if self.m > self.row_pa:
            th = np.abs(qe[:, :, 2])
            a = np.empty((qe.shape[0], self.m - self.row_pa))
            a[:, : self.P] = th[:, self.pi] + th[:, self.pj] + np.abs(self.pth0)
            if self.crank is not None:
                a[:, self.P] = th[:, self.crank] + np.abs(self.driver_angle(t))
            tol[:, self.row_pa:] = np.maximum(POSITION_TOL, 8 * _EPS * a)
        return tol

    def newton(self, q0, t, where):
        """Newton-Raphson on Phi(q, t) = 0 from q0 [nb, 3]; least-norm steps when m < n."""
        qe = self.extend(np.asarray(q0, float).reshape(1, self.nb, 3))
        tt = np.array([t], float)
        square = self.m == self.n
        res = np.inf
        for it in range(MAX_NEWTON_ITER + 1):
            geo = self._geometry(qe)
            F = self.phi(qe, tt, geo)
            res = float(np.max(np.abs(F))) if self.m else 0.0
            if not np.isfinite(res):
                break
            if res <= POSITION_TOL or (res < 1e-9 and np.all(np.abs(F) <= self.tolerance(qe, tt))):
                return qe[0, : self.nb].copy(), it
            if it == MAX_NEWTON_ITER:
                break
            J = self.jac(qe, geo)[0]
            try:
                if square:
                    dq = np.linalg.solve(J, -F[0])
                else:
                    dq = np.linalg.lstsq(J, -F[0], rcond=None)[0]
            except np.linalg.LinAlgError:
                raise SolveError(f"ideal assembly {where}: constraint Jacobian is singular "
                                 f"(iteration {it}, residual {res:.3g})") from None
            if not np.all(np.isfinite(dq)):
                raise SolveError(f"ideal assembly {where}: constraint Jacobian is singular "
                                 f"(iteration {it}, residual {res:.3g})")
            qe[0, : self.nb] += dq.reshape(self.nb, 3)
        joint, gap = self.worst_joint(F[0]) if np.all(np.isfinite(F)) else (None, res)
        raise NotClosed(f"ideal assembly {where}: Newton-Raphson did not converge in "
                        f"{MAX_NEWTON_ITER} iterations (max |Phi| = {res:.3g}, tolerance "
                        f"{POSITION_TOL:g} m); the mechanism may not close with these lengths "
                        f"or the angle hints pick no reachable configuration", joint, gap)

    def worst_joint(self, F):
        """(name, residual) of the joint (or "driver") with the largest constraint residual."""
        names = [None] * self.m
        for k, jn in enumerate(self.rev_names):
            names[self.rev_r0[k]] = names[self.rev_r1[k]] = jn
        for k, jn in enumerate(self.pri_names):
            names[self.pn_rows[k]] = names[self.row_pa + k] = jn
        if self.crank is not None:
            names[self.row_drv] = "driver"
        i = int(np.argmax(np.abs(F)))
        return names[i], float(abs(F[i]))

    def loop_of(self, joint: str) -> list[str]:
        """The joints of the shortest loop through ``joint`` (it first), [joint] if none."""
        sc = self.scene
        if joint not in sc.joints:
            return [joint]
        a, b = sc.joints[joint].bodies
        prev = {a: None}
        queue = [a]
        while queue:
            body = queue.pop(0)
            if body == b:
                break
            for jn, j in sc.joints.items():
                if jn == joint or body not in j.bodies:
                    continue
                other = j.bodies[1] if j.bodies[0] == body else j.bodies[0]
                if other not in prev:
                    prev[other] = (body, jn)
                    queue.append(other)
        if b not in prev:
            return [joint]
        path, body = [], b
        while prev[body] is not None:
            body, jn = prev[body]
            path.append(jn)
        return [joint] + path[::-1]

    def check_rank(self, J, where, need_full_column_rank=False):
        """SolveError when the Jacobians [N, m, n] are singular (condition number > 1e12)."""
        if self.m == 0:
            if need_full_column_rank and self.n:
                raise SolveError(f"ideal solution {where}: no constraints, the motion is not determined")
            return
        s = np.linalg.svd(J, compute_uv=False)
        r = min(self.m, self.n)
        bad = s[:, r - 1] <= s[:, 0] / _COND_MAX
        if np.any(bad):
            k = int(np.argmax(bad))
            raise SolveError(f"ideal solution {where[k] if not isinstance(where, str) else where}: "
                             f"constraint Jacobian is singular (condition number "
                             f"{s[k, 0] / max(s[k, r - 1], 1e-300):.3g}); a dead-centre or locked "
                             f"configuration, or redundant constraints")
        if need_full_column_rank and self.m < self.n:
            raise SolveError(f"ideal solution: {self.n - self.m} coordinate(s) are not determined by "
                             f"the joints and the driver; inverse dynamics needs a kinematically "
                             f"driven mechanism (m = n)")

    def solve_lin(self, J, b):
        """Solve J x = b for stacks [N, m, n], [N, m]; least-norm / least-squares otherwise."""
        if self.m == self.n:
            return np.linalg.solve(J, b[..., None])[..., 0]
        return np.einsum("nij,nj->ni", np.linalg.pinv(J), b)

    # ------------------------------------------------------------------ applied loads
    def point_state(self, qe, qde, b, s):
        """Global position, velocity and rotated vector a = A s of points s [K, 2] of bodies b [K]."""
        a = _rotate(qe[:, b, 2], s)
        p = qe[:, b, :2] + a
        v = qde[:, b, :2] + _perp(a) * qde[:, b, 2][..., None]
        return p, v, a

    def applied(self, qe, qde):
        """Applied generalized forces Q [N, nb, 3], potential energy [N], power of the
        non-conservative loads [N]."""
        sc = self.scene
        N = qe.shape[0]
        Q = np.zeros((N, self.nb + 1, 3))
        gvec = np.asarray(sc.gravity, float)
        Q[:, : self.nb, 0] += self.mass * gvec[0]
        Q[:, : self.nb, 1] += self.mass * gvec[1]
        V = -np.einsum("b,nbk,k->n", self.mass, qe[:, : self.nb, :2], gvec)
        P = np.zeros(N)
        for li, ld in enumerate(sc.loads):
            path = f"loads.{li}"
            if ld.type in ("force", "torque"):
                if ld.body not in self.idx:
                    raise SceneError(f"{path}.body", ld.body, "must name a body")
                b = self.idx[ld.body]
                f = self.modulation(ld, qe, b, path)
                if ld.type == "force":
                    pts = sc.ground_points if ld.body == "ground" else sc.bodies[ld.body].points
                    if ld.point not in pts:
                        raise SceneError(f"{path}.point", ld.point, f"must name a point of {ld.body}")
                    s = np.asarray(pts[ld.point], float).reshape(1, 2)
                    val = np.asarray(ld.value, float).reshape(2)
                    F = f[:, None] * val                     # [N, 2]
                    _, v, a = self.point_state(qe, qde, np.array([b]), s)
                    Q[:, b, :2] += F
                    Q[:, b, 2] += _cross(a[:, 0], F)
                    P += np.einsum("nk,nk->n", F, v[:, 0])
                else:
                    T = f * float(np.asarray(ld.value, float).reshape(()))
                    Q[:, b, 2] += T
                    P += T * qde[:, b, 2]
            elif ld.type == "spring":
                bs = []
                ss = []
                for k in range(2):
                    bn, pn = ld.bodies[k], ld.points[k]
                    if bn not in self.idx:
                        raise SceneError(f"{path}.bodies", list(ld.bodies), "must name bodies or 'ground'")
                    pts = sc.ground_points if bn == "ground" else sc.bodies[bn].points
                    if pn not in pts:
                        raise SceneError(f"{path}.points", list(ld.points), f"must name points of {bn}")
                    bs.append(self.idx[bn])
                    ss.append(pts[pn])
                p, v, a = self.point_state(qe, qde, np.array(bs), np.asarray(ss, float))
                d = p[:, 1] - p[:, 0]
                L = np.hypot(d[:, 0], d[:, 1])
                if np.any(L <= 0.0):
                    raise SolveError(f"{path}: spring of zero length, its direction is undefined")
                u = d / L[:, None]
                Ld = np.einsum("nk,nk->n", u, v[:, 1] - v[:, 0])
                fe = ld.stiffness * (L - ld.free_length)
                fd = ld.damping * Ld
                F0 = (fe + fd)[:, None] * u                  # force on the first point (tension > 0)
                Q[:, bs[0], :2] += F0
                Q[:, bs[0], 2] += _cross(a[:, 0], F0)
                Q[:, bs[1], :2] -= F0
                Q[:, bs[1], 2] -= _cross(a[:, 1], F0)
                V += 0.5 * ld.stiffness * (L - ld.free_length) ** 2
                P -= fd * Ld
            else:
                raise SceneError(f"{path}.type", ld.type, "must be 'force', 'torque' or 'spring'")
        return Q[:, : self.nb], V, P

    def modulation(self, ld, qe, b, path):
        """Modulation factor [N] of a force or torque load (docs/scene-format.md)."""
        N = qe.shape[0]
        mod = ld.modulation
        if mod == "constant":
            return np.ones(N)
        if mod == "angle_threshold":
            return np.where(qe[:, b, 2] <= ld.threshold, 1.0, -1.0)
        if mod in ("crank_halves", "crank_table"):
            if self.crank is None:
                raise SceneError(f"{path}.modulation", mod, "needs a driver (crank angle)")
            phi = np.mod(qe[:, self.crank, 2], TWO_PI)
            if mod == "crank_halves":
                return np.where((phi > 0.0) & (phi < np.pi), 1.0, -1.0)
            xa = np.asarray(ld.table_angles, float)
            ya = np.asarray(ld.table_values, float)
            if xa.size == 0 or xa.size != ya.size:
                raise SceneError(f"{path}.table_angles", list(ld.table_angles),
                                 "needs as many angles as table_values, at least one")
            return np.interp(phi, xa, ya, period=TWO_PI)
        raise SceneError(f"{path}.modulation", mod,
                         "must be one of constant, crank_halves, angle_threshold, crank_table")


_PREDICT_MAX_STEP = 0.2     # rad of crank rotation: larger steps start Newton from the previous solution


def _lagrange_weights(ts, x):
    """Weights of the Lagrange polynomial through the nodes ts evaluated at x (None if two nodes
    coincide)."""
    n = len(ts)
    L = np.ones(n)
    for a in range(n):
        for b in range(n):
            if a != b:
                d = ts[a] - ts[b]
                if d == 0.0:
                    return None
                L[a] *= (x - ts[b]) / d
    return L


def _model(scene: Scene) -> _Model:
    return _Model(scene)


def assemble(scene: Scene, t: float = 0.0, guess=None):
    """Assembled position and velocity of the ideal mechanism at time t.

    Returns ``(q, qd)``, arrays of shape (nb, 3): rows are the bodies in the order of
    ``scene.bodies``, columns (x, y, theta) of the centre of mass and their time derivatives.

    Position: Newton-Raphson on the constraint equations Phi(q, t) = 0 (every joint ideal,
    clearance joints closed, the driver constraint theta_crank = angle0 + speed t), tolerance
    1e-13 m on max |Phi| (angle rows: a few ulps of the angles), at most 50 iterations. The start
    is ``guess`` when given, otherwise bodies placed along the joints from the ground with their
    ``angle0`` hints (the crank at the driver angle), which selects the assembly branch.
    Velocity: Phi_q qd = -Phi_t.

    A driver in torque mode is assembled like a speed driver (its ``speed`` is the initial speed).
    If the joints and driver leave coordinates free (fewer constraints than 3 nb), the Newton
    steps and the velocity are least-norm solutions: the position found is a nearby one on the
    constraint manifold, not a unique one, and the free velocity components are zero in the
    least-norm sense.

    Raises SolveError when Newton does not converge or the Jacobian is singular.
    """
    mdl = _model(scene)
    q0 = mdl.initial_guess(t) if guess is None else np.asarray(guess, float).reshape(mdl.nb, 3)
    try:
        q, _ = mdl.newton(q0, t, f"at t = {t:g} s")
    except NotClosed:
        if guess is not None:
            raise
        raise cannot_assemble(mdl, t) from None
    qe = mdl.extend(q[None])
    J = mdl.jac(qe)
    mdl.check_rank(J, f"at t = {t:g} s")
    qd = mdl.solve_lin(J, -mdl.phi_t()[None])[0]
    return q, qd.reshape(mdl.nb, 3)


class NotClosed(SolveError):
    """Newton-Raphson found no configuration (a SolveError: exit status 1 during a motion; at the
    start it becomes an AssemblyError, bad input). joint, gap: the joint of the largest residual."""

    def __init__(self, message: str, joint: str | None, gap: float):
        super().__init__(message)
        self.joint = joint
        self.gap = gap


def cannot_assemble(mdl, t: float) -> AssemblyError:
    """The one-line error of a mechanism that Newton-Raphson could not assemble at time t.

    The loop that cannot close, its gap and the reason come from the geometry
    (:func:`nld.model.closure.diagnose`), never from the failed iterate, whose largest residual
    depends on rounding. When the geometry shows no loop that cannot close, the error says so and
    names no joint (the angle0 hints may start too far from every configuration)."""
    from nld.model.closure import diagnose
    sc = mdl.scene
    found = diagnose(mdl, t)
    head = f"scene {sc.name!r} cannot be assembled at t = {t:g} s: "
    if found is None:
        return AssemblyError(head + "Newton-Raphson from the angle0 hints found no configuration that "
                             "closes every joint, although no loop is too long or too short to close "
                             "on its own; check the bodies' points, ground.points and the angle0 hints "
                             "(they pick the assembly branch)")
    return AssemblyError(head + f"the loop of joints {'-'.join(found.loop)} (bodies "
                         f"{', '.join(found.bodies)}) does not close at joint {found.joint} "
                         f"(gap {found.gap:.3g} m): {found.reason}; check the link lengths (the bodies' points) and "
                         "ground.points", found.joint, found.gap)


def ideal_solution(scene: Scene, times) -> pd.DataFrame:
    """Ideal-joint kinematics and inverse dynamics of a speed-driven scene at the given times.

    Positions by Newton-Raphson at each time, warm-started from the previous time (the first from
    :func:`assemble`'s guess; when the crank turns at most 0.2 rad per step the start is the
    quadratic extrapolation of the last three solutions); velocities from Phi_q qd = -Phi_t, accelerations from
    Phi_q qdd = gamma, multipliers from Phi_q^T lambda = M qdd - Q_applied. Columns (SI units):
    ``t``, ``driver.angle`` (unwrapped crank angle, rad), ``driver.speed``, ``driver.torque``
    (torque the driver applies to the crank, N m), per body ``b.x b.y b.theta b.vx b.vy b.omega
    b.ax b.ay b.alpha``, per joint ``j.Fx j.Fy`` (reaction force on the first body of the joint
    exerted by the second, N) and for prismatic joints ``j.M`` (reaction couple on the first
    body, N m, moment about the sliding point), then ``energy.kinetic``, ``energy.potential``
    (gravity -m g.r plus springs), ``energy.total``, ``power.driver`` (driver torque x crank
    speed), ``power.loads`` (forces, torques and spring dampers, W).
    """
    mdl = _model(scene)
    if mdl.crank is None:
        raise SceneError("driver", None, "ideal_solution needs a driver in speed mode")
    if mdl.drv_mode != "speed":
        raise SceneError("driver.mode", mdl.drv_mode, "ideal_solution needs mode = 'speed'")
    t = np.atleast_1d(np.asarray(times, float)).ravel()
    N = t.size
    if N == 0:
        raise SceneError("times", [], "needs at least one time")
    nb = mdl.nb

    # positions, sequentially (warm start from the previous time)
    q = np.empty((N, nb, 3))
    qk = mdl.initial_guess(t[0])
    w = abs(mdl.drv_speed)
    for k in range(N):
        if k >= 2 and w * abs(t[k] - t[k - 1]) <= _PREDICT_MAX_STEP:
            # polynomial extrapolation through the last (up to) three solutions
            ts = t[max(0, k - 3):k]
            L = _lagrange_weights(ts, t[k])
            if L is not None:
                qk = np.tensordot(L, q[max(0, k - 3):k], axes=1)
        try:
            qk, _ = mdl.newton(qk, t[k], f"at t = {t[k]:g} s")
        except NotClosed:
            if k > 0:
                raise                 # the motion reached a locked configuration: a SolveError
            raise cannot_assemble(mdl, float(t[0])) from None
        q[k] = qk

    qe = mdl.extend(q)
    geo = mdl._geometry(qe)
    J = mdl.jac(qe, geo)
    mdl.check_rank(J, [f"at t = {x:g} s" for x in t], need_full_column_rank=True)
    qd = mdl.solve_lin(J, np.broadcast_to(-mdl.phi_t(), (N, mdl.m)).copy())
    qde = mdl.extend(qd.reshape(N, nb, 3))
    gam = mdl.gamma(qe, qde, geo)
    qdd = mdl.solve_lin(J, gam)

    Q, V, Pload = mdl.applied(qe, qde)
    Mdiag = np.repeat(np.stack((mdl.mass, mdl.mass, mdl.inertia), axis=1).reshape(1, -1), N, axis=0)
    rhs = Mdiag * qdd - Q.reshape(N, -1)
    # Phi_q^T lambda = M qdd - Q   (square, full rank: checked above; least squares if m > n)
    JT = np.swapaxes(J, 1, 2)
    if mdl.m == mdl.n:
        lam = np.linalg.solve(JT, rhs[..., None])[..., 0]
    else:
        lam = np.einsum("nij,nj->ni", np.linalg.pinv(JT), rhs)

    qd3 = qd.reshape(N, nb, 3)
    qdd3 = qdd.reshape(N, nb, 3)
    cols: dict[str, np.ndarray] = {}
    cols["t"] = t
    cols["driver.angle"] = q[:, mdl.crank, 2]
    cols["driver.speed"] = qd3[:, mdl.crank, 2]
    tau = lam[:, mdl.row_drv]
    cols["driver.torque"] = tau
    for k, name in enumerate(mdl.names):
        for c, arr, lab in ((0, q, "x"), (1, q, "y"), (2, q, "theta"),
                            (0, qd3, "vx"), (1, qd3, "vy"), (2, qd3, "omega"),
                            (0, qdd3, "ax"), (1, qdd3, "ay"), (2, qdd3, "alpha")):
            cols[f"{name}.{lab}"] = arr[:, k, c]
    _, _, n, _, _ = geo
    rev_pos = {nm: k for k, nm in enumerate(mdl.rev_names)}
    pri_pos = {nm: k for k, nm in enumerate(mdl.pri_names)}
    for jn in scene.joints:
        if jn in rev_pos:
            k = rev_pos[jn]
            cols[f"{jn}.Fx"] = lam[:, mdl.rev_r0[k]]
            cols[f"{jn}.Fy"] = lam[:, mdl.rev_r1[k]]
        else:
            k = pri_pos[jn]
            l1 = lam[:, mdl.row_pn + k]
            cols[f"{jn}.Fx"] = -l1 * n[:, k, 0]
            cols[f"{jn}.Fy"] = -l1 * n[:, k, 1]
            cols[f"{jn}.M"] = -lam[:, mdl.row_pa + k]
    T = 0.5 * (np.einsum("b,nbk->n", mdl.mass, qd3[:, :, :2] ** 2)
               + np.einsum("b,nb->n", mdl.inertia, qd3[:, :, 2] ** 2))
    cols["energy.kinetic"] = T
    cols["energy.potential"] = V
    cols["energy.total"] = T + V
    cols["power.driver"] = tau * qd3[:, mdl.crank, 2]
    cols["power.loads"] = Pload
    return pd.DataFrame(cols)


def loop_closure_error(scene: Scene, df: pd.DataFrame) -> float:
    """Max over the table's times and the scene's joints of |constraint violation|.

    Recomputed from the columns ``b.x``, ``b.y``, ``b.theta``: both components of every revolute
    joint (m, clearance joints taken as closed), the normal offset of every prismatic joint from
    its guide line (m) and its relative-angle violation (rad, counted as is). The driver
    constraint is not a joint and is not included.
    """
    mdl = _model(scene)
    N = len(df)
    if N == 0 or mdl.row_drv == 0:
        return 0.0
    q = np.empty((N, mdl.nb, 3))
    for k, name in enumerate(mdl.names):
        q[:, k, 0] = df[f"{name}.x"].to_numpy(float)
        q[:, k, 1] = df[f"{name}.y"].to_numpy(float)
        q[:, k, 2] = df[f"{name}.theta"].to_numpy(float)
    t = df["t"].to_numpy(float) if "t" in df else np.zeros(N)
    F = mdl.phi(mdl.extend(q), t)[:, : mdl.row_drv]
    return float(np.max(np.abs(F)))
