"""Generate the numba source of a scene's kernel: only the terms the scene has.

The kernel implements the minimal-coordinate equations of docs/formulation.md:

    M(q) q'' = Q(q, q', t) - h(q, q', t)        (tree of ideal joints, clearance joints as forces)

with M = sum_b m_b J_b^T J_b + I_b Jt_b^T Jt_b, h = sum_b m_b J_b^T a_b^bias (velocity terms) and Q the
generalised applied forces (contact, friction, gravity, loads). Jacobians are geometric: for a joint
angle with world pivot P, d r_X / d q = z x (r_X - P); for a slide, the world guide direction.
Loops of ideal joints add constraints Phi(q) = 0 solved by Newton for dependent coordinates and the
augmented system [M Phi_q^T; Phi_q 0] for the accelerations.

Generated functions (all ``@njit(cache=True)``):
    rhs(t, y, p, z, dy)            state y = [q_I, q_I'] (independent coordinates)
    events(t, y, p, z, g)          penetration of each clearance joint (m), switches of loads
    on_event(k, direction, t, y, p, z)   records the approach velocity at contact onset
    observe(t, y, p, z, row)       every observable column (see columns())
"""
from __future__ import annotations

from nld.laws.law import ContactLaw, contact_law, contact_laws
from nld.model.scene_model import Scene
from nld.model.topology import GROUND, Topology


def law_of(joint) -> ContactLaw:
    """The registered contact law of a clearance joint (nld.laws.law)."""
    return contact_law(joint.contact.law)


def needs_onset_velocity(joint) -> bool:
    """The joint's law divides by the approach velocity stored at the located onset (z[ci])."""
    return law_of(joint).onset_velocity


def friction_present(joint) -> bool:
    f = joint.friction
    return (f.law != "none" and f.mu > 0.0) or f.tangential_damping > 0.0


def hybrid_coulomb(joint) -> bool:
    """A clearance joint whose Coulomb friction runs as hybrid modes (free / slip+ / slip- / stick)."""
    return joint.friction.law == "coulomb" and joint.friction.mu > 0.0


SWITCHED = ("crank_halves", "angle_threshold")


class ZLayout:
    """Where each entry of the kernel's discrete state z lives, and the order of its events.

    z = [v_minus or contact flag per clearance joint | dependent coordinates (loops' Newton warm start)
         | branch (+1/-1) per switched load | (mode, sigma_v, sigma_f, vt0) per hybrid Coulomb joint
         | sigma_c per hertz_damped joint].

    vt0: the slip velocity when the slip began (m/s; 0 from a contact onset). The slip event watches
    s (vt - vt0): it starts at exactly zero and grows, even where vt kept a round-off residual of
    the other sign from the preceding stick (a stick -> slip -> stick loop at one instant).

    hertz_damped's flag z[j]: > 0 contact, < 0 contact with the force clamped at zero (K d^n + C d'
    has fallen through 0 during restitution: a located kink), 0 free.

    mode: 0 free (no contact), 1 slip+, -1 slip-, 2 stick (docs/contact-laws.md, "Modes").
    sigma_v, sigma_f: the sign the integrator tracks for the joint's slip-velocity and stick-margin
    events. Each event function is g = sigma * h with h > 0 while no switch is due (h = 1 when
    the function is not active in the mode); on_event sets sigma to the crossing's direction, so
    the function starts every new mode on the side the integrator has recorded and never fires
    again at once because of the switch itself.

    Events: [penetration per clearance joint | switched loads | (slip velocity, stick margin) per
    hybrid joint | clamp per hertz_damped joint]."""

    def __init__(self, scene: Scene, topo: Topology):
        nc, nd = len(topo.clearance), len(topo.dependent)
        self.n_clear = nc
        i = nc + nd
        e = nc
        self.load: dict[int, int] = {}
        self.ev_load: dict[int, int] = {}
        for li, ld in enumerate(scene.loads):
            if ld.modulation in SWITCHED:
                self.load[li], self.ev_load[li] = i, e
                i += 1
                e += 1
        self.hybrid: list[int] = [ci for ci, jn in enumerate(topo.clearance) if hybrid_coulomb(scene.joints[jn])]
        self.mode, self.sig_v, self.sig_f, self.ev_v, self.ev_f, self.vt0 = {}, {}, {}, {}, {}, {}
        for ci in self.hybrid:
            self.mode[ci], self.sig_v[ci], self.sig_f[ci], self.vt0[ci] = i, i + 1, i + 2, i + 3
            self.ev_v[ci], self.ev_f[ci] = e, e + 1
            i += 4
            e += 2
        # laws with a jump at onset (hertz_damped): the zero of the unclamped force during
        # restitution (the clamp at F = 0, a kink)
        self.clamp: list[int] = [ci for ci, jn in enumerate(topo.clearance)
                                 if law_of(scene.joints[jn]).jump_at_onset]
        self.sig_c, self.ev_c = {}, {}
        for ci in self.clamp:
            self.sig_c[ci], self.ev_c[ci] = i, e
            i += 1
            e += 1
        self.n = i
        self.n_events = e
        names = list(topo.clearance) + [f"load{li}" for li in self.load]
        for ci in self.hybrid:
            names += [f"{topo.clearance[ci]}.slip", f"{topo.clearance[ci]}.stick"]
        names += [f"{topo.clearance[ci]}.clamp" for ci in self.clamp]
        self.event_names = names


def structure_key(scene: Scene, topo: Topology) -> dict:
    """Everything that changes the kernel's code (and nothing that is only a number)."""
    return {
        "bodies": topo.body_names,
        "points": {b.name: sorted(b.points) for b in scene.bodies.values()},
        "ground": sorted(scene.ground_points),
        "edges": [(e.kind, e.joint, e.parent, e.parent_point, e.child_point, e.coords) for e in topo.edges],
        "order": topo.order,
        "coords": [(c.kind, c.body) for c in topo.coords],
        "cuts": [(n, scene.joints[n].bodies, scene.joints[n].points) for n in topo.cuts],
        "dependent": topo.dependent,
        "rheonomic": topo.rheonomic,
        "clearance": [(n, scene.joints[n].bodies, scene.joints[n].points, scene.joints[n].contact.law,
                       scene.joints[n].friction.law if friction_present(scene.joints[n]) else "none",
                       scene.joints[n].friction.tangential_damping > 0,
                       hybrid_coulomb(scene.joints[n])) for n in topo.clearance],
        "gravity": [g != 0.0 for g in scene.gravity],
        "driver": None if scene.driver is None else (scene.driver.joint, scene.driver.mode),
        "loads": [(ld.type, ld.body, ld.point, ld.bodies, ld.points, ld.modulation, len(ld.table_angles))
                  for ld in scene.loads],
        "laws": law_fingerprint(scene, topo),
    }


def law_fingerprint(scene: Scene, topo: Topology) -> dict:
    """Hash of the source of each contact law the scene uses. The generator digest covers the laws
    in nld/laws/; this covers a law registered from outside the package (nld.laws.law.register)."""
    import hashlib
    import inspect
    out = {}
    for nm in sorted({scene.joints[jn].contact.law for jn in topo.clearance}):
        src = "".join(inspect.getsource(f.py_func if hasattr(f, "py_func") else f)
                      for f in contact_law(nm).functions())
        out[nm] = hashlib.sha1(src.encode()).hexdigest()[:12]
    return out


class Emitter:
    def __init__(self, scene: Scene, topo: Topology, layout):
        self.scene, self.topo, self.L = scene, topo, layout
        self.Z = ZLayout(scene, topo)
        self.lines: list[str] = []
        self.ind = 1

    # --- helpers -------------------------------------------------------------------
    def w(self, s: str = ""):
        self.lines.append("    " * self.ind + s)

    def P(self, name: str, k: int | None = None) -> str:
        i = self.L.index[name]
        return f"p[{i + (k or 0)}]"

    def point_param(self, body: int, pname: str) -> tuple[str, str]:
        base = (f"ground.points.{pname}" if body == GROUND
                else f"bodies.{self.topo.body_names[body]}.points.{pname}")
        return self.P(base, 0), self.P(base, 1)

    def world_point(self, body: int, pname: str, tag: str, vel: bool = True, acc: bool = False):
        """Emit world position (and velocity, bias acceleration) of a body point; returns var prefix."""
        px, py = self.point_param(body, pname)
        if body == GROUND:
            self.w(f"{tag}x = {px}; {tag}y = {py}")
            if vel:
                self.w(f"{tag}vx = 0.0; {tag}vy = 0.0")
            if acc:
                self.w(f"{tag}ax = 0.0; {tag}ay = 0.0")
            return
        b = body
        self.w(f"{tag}dx = c{b}*{px} - s{b}*{py}; {tag}dy = s{b}*{px} + c{b}*{py}")
        self.w(f"{tag}x = x{b} + {tag}dx; {tag}y = y{b} + {tag}dy")
        if vel:
            self.w(f"{tag}vx = vx{b} - w{b}*{tag}dy; {tag}vy = vy{b} + w{b}*{tag}dx")
        if acc:
            self.w(f"{tag}ax = ax{b} - al{b}*{tag}dy - w{b}*w{b}*{tag}dx; "
                   f"{tag}ay = ay{b} + al{b}*{tag}dx - w{b}*w{b}*{tag}dy")

    def jac(self, k: int, X: str, Y: str) -> tuple[str, str, str]:
        """Jacobian (dx/dq_k, dy/dq_k, dtheta/dq_k) of a world point (X, Y) of a body moved by q_k."""
        kind = self.topo.coords[k].kind
        if kind in ("crank", "rev", "fth"):
            return f"(-({Y} - py{k}))", f"({X} - px{k})", "1.0"
        if kind == "pri":
            return f"ux{k}", f"uy{k}", "0.0"
        if kind == "fx":
            return "1.0", "0.0", "0.0"
        return "0.0", "1.0", "0.0"   # fy

    # --- kinematics ------------------------------------------------------------------
    def coords_from_state(self, mode: str):
        """q{k}, qd{k} for every coordinate; dependent ones are solved later (loops)."""
        t = self.topo
        n_ind = len(t.independent)
        for c in t.rheonomic:
            self.w(f"q{c} = {self.P('driver.angle0')} + {self.P('driver.speed')}*t; qd{c} = {self.P('driver.speed')}")
        for i, k in enumerate(t.independent):
            self.w(f"q{k} = y[{i}]; qd{k} = y[{n_ind + i}]")

    def positions(self):
        t = self.topo
        for b in t.order:
            e = t.edges[b]
            if e.kind == "free":
                kx, ky, kt = e.coords
                self.w(f"th{b} = q{kt}; x{b} = q{kx}; y{b} = q{ky}")
                self.w(f"c{b} = np.cos(th{b}); s{b} = np.sin(th{b})")
                self.w(f"px{kt} = x{b}; py{kt} = y{b}")
                continue
            k = e.coords[0]
            par = e.parent
            pth = "0.0" if par == GROUND else f"th{par}"
            if e.kind in ("crank", "rev"):
                self.world_point(par, e.parent_point, f"J{k}", vel=False)
                self.w(f"px{k} = J{k}x; py{k} = J{k}y")
                self.w(f"th{b} = {pth} + q{k}" if par != GROUND else f"th{b} = q{k}")
                self.w(f"c{b} = np.cos(th{b}); s{b} = np.sin(th{b})")
                bx, by = self.point_param(b, e.child_point)
                self.w(f"d{b}x = c{b}*{bx} - s{b}*{by}; d{b}y = s{b}*{bx} + c{b}*{by}")
                self.w(f"x{b} = J{k}x - d{b}x; y{b} = J{k}y - d{b}y")
            else:  # prismatic
                self.world_point(par, e.parent_point, f"G{k}", vel=False)
                ax_, ay_ = self.P(f"joints.{e.joint}.axis", 0), self.P(f"joints.{e.joint}.axis", 1)
                if par == GROUND:
                    self.w(f"ux{k} = {ax_}; uy{k} = {ay_}")
                else:
                    self.w(f"ux{k} = c{par}*{ax_} - s{par}*{ay_}; uy{k} = s{par}*{ax_} + c{par}*{ay_}")
                self.w(f"Sx{k} = G{k}x + q{k}*ux{k}; Sy{k} = G{k}y + q{k}*uy{k}")
                self.w(f"th{b} = {pth} + {self.P(f'joints.{e.joint}.angle_offset')}")
                if par == GROUND:   # a slider on a fixed guide never turns: no trigonometry per call
                    self.w(f"c{b} = {self.P(f'joints.{e.joint}.angle_offset_cos')}; "
                           f"s{b} = {self.P(f'joints.{e.joint}.angle_offset_sin')}")
                else:
                    self.w(f"c{b} = np.cos(th{b}); s{b} = np.sin(th{b})")
                bx, by = self.point_param(b, e.child_point)
                self.w(f"d{b}x = c{b}*{bx} - s{b}*{by}; d{b}y = s{b}*{bx} + c{b}*{by}")
                self.w(f"x{b} = Sx{k} - d{b}x; y{b} = Sy{k} - d{b}y")

    def velocities(self, bias: bool):
        """Body velocities and, if bias, accelerations with zero independent accelerations."""
        t = self.topo
        for b in t.order:
            e = t.edges[b]
            if e.kind == "free":
                kx, ky, kt = e.coords
                self.w(f"w{b} = qd{kt}; vx{b} = qd{kx}; vy{b} = qd{ky}")
                if bias:
                    self.w(f"al{b} = 0.0; ax{b} = 0.0; ay{b} = 0.0")
                continue
            k = e.coords[0]
            par = e.parent
            if par == GROUND:
                self.w(f"Jv{k}x = 0.0; Jv{k}y = 0.0")
                if bias:
                    self.w(f"Ja{k}x = 0.0; Ja{k}y = 0.0")
                pw, pal = "0.0", "0.0"
            else:
                pw, pal = f"w{par}", f"al{par}"
                tag = "J" if e.kind in ("crank", "rev") else "G"
                self.w(f"r{k}x = {tag}{k}x - x{par}; r{k}y = {tag}{k}y - y{par}")
                if e.kind == "pri":
                    self.w(f"r{k}x += q{k}*ux{k}; r{k}y += q{k}*uy{k}")
                self.w(f"Jv{k}x = vx{par} - w{par}*r{k}y; Jv{k}y = vy{par} + w{par}*r{k}x")
                if bias:
                    self.w(f"Ja{k}x = ax{par} - al{par}*r{k}y - w{par}*w{par}*r{k}x; "
                           f"Ja{k}y = ay{par} + al{par}*r{k}x - w{par}*w{par}*r{k}y")
            if e.kind in ("crank", "rev"):
                self.w(f"w{b} = {pw} + qd{k}" if par != GROUND else f"w{b} = qd{k}")
                if bias:
                    self.w(f"al{b} = {pal}")
            else:
                self.w(f"Jv{k}x += qd{k}*ux{k}; Jv{k}y += qd{k}*uy{k}")
                if bias and par != GROUND:
                    self.w(f"Ja{k}x += -2.0*w{par}*qd{k}*uy{k}; Ja{k}y += 2.0*w{par}*qd{k}*ux{k}")
                self.w(f"w{b} = {pw}")
                if bias:
                    self.w(f"al{b} = {pal}")
            self.w(f"vx{b} = Jv{k}x + w{b}*d{b}y; vy{b} = Jv{k}y - w{b}*d{b}x")
            if bias:
                self.w(f"ax{b} = Ja{k}x + al{b}*d{b}y + w{b}*w{b}*d{b}x; "
                       f"ay{b} = Ja{k}y - al{b}*d{b}x + w{b}*w{b}*d{b}y")

    # --- generalised forces --------------------------------------------------------
    def add_force(self, body: int, X: str, Y: str, FX: str, FY: str, coords: list[int]):
        """Q_k += F . d r_X / d q_k for every coordinate k in coords moving the body."""
        if body == GROUND:
            return
        anc = set(self.topo.ancestors(body))
        for k in coords:
            if k not in anc:
                continue
            jx, jy, _ = self.jac(k, X, Y)
            terms = []
            if jx != "0.0":
                terms.append(f"{FX}*{jx}" if jx != "1.0" else FX)
            if jy != "0.0":
                terms.append(f"{FY}*{jy}" if jy != "1.0" else FY)
            if terms:
                self.w(f"Q{k} += " + " + ".join(terms))

    def add_torque(self, body: int, TQ: str, coords: list[int]):
        if body == GROUND:
            return
        anc = set(self.topo.ancestors(body))
        for k in coords:
            if k in anc and self.topo.coords[k].kind in ("crank", "rev", "fth"):
                self.w(f"Q{k} += {TQ}")

    def modulation(self, i: int, ld) -> str:
        t = self.topo
        if ld.modulation == "constant":
            return "1.0"
        if ld.modulation in SWITCHED:
            # the branch the last located event chose (z, set by on_event / init_modes), never the
            # sign of a continuous quantity: within a step the load is smooth (issue 14)
            self.w(f"fm{i} = z[{self.Z.load[i]}]")
            return f"fm{i}"
        n = len(ld.table_angles)
        ia, iv = self.L.index[f"loads.{i}.table_angles"], self.L.index[f"loads.{i}.table_values"]
        self.w(f"fm{i} = periodic_table(q{t.crank_coord}, p, {ia}, {iv}, {n})")
        return f"fm{i}"

    def forces(self, coords: list[int], observe: bool):
        """Contact, friction, gravity and loads as generalised forces Q{k} for k in coords."""
        sc, t = self.scene, self.topo
        for k in coords:
            self.w(f"Q{k} = 0.0")
        if observe:
            self.w("Vpot = 0.0; Pload = 0.0")
        gx, gy = sc.gravity
        if gx != 0.0 or gy != 0.0:
            for b in t.order:
                m = self.P(f"bodies.{t.body_names[b]}.mass")
                self.add_force(b, f"x{b}", f"y{b}", f"({m}*{self.P('gravity', 0)})",
                               f"({m}*{self.P('gravity', 1)})", coords)
                if observe:
                    self.w(f"Vpot -= {m}*({self.P('gravity', 0)}*x{b} + {self.P('gravity', 1)}*y{b})")
        for ci, jn in enumerate(t.clearance):
            self.clearance_force(ci, jn, coords, observe)
        for i, ld in enumerate(sc.loads):
            fm = self.modulation(i, ld)
            if ld.type == "force":
                b = t.body_index(ld.body)
                self.world_point(b, ld.point, f"L{i}", vel=observe)
                fx, fy = self.P(f"loads.{i}.value", 0), self.P(f"loads.{i}.value", 1)
                self.w(f"L{i}fx = {fm}*{fx}; L{i}fy = {fm}*{fy}")
                self.add_force(b, f"L{i}x", f"L{i}y", f"L{i}fx", f"L{i}fy", coords)
                if observe:
                    self.w(f"Pload += L{i}fx*L{i}vx + L{i}fy*L{i}vy")
            elif ld.type == "torque":
                b = t.body_index(ld.body)
                self.w(f"L{i}tq = {fm}*{self.P(f'loads.{i}.value')}")
                self.add_torque(b, f"L{i}tq", coords)
                if observe and b != GROUND:
                    self.w(f"Pload += L{i}tq*w{b}")
            else:  # spring between two points: force on the first point toward the second when stretched
                b0, b1 = t.body_index(ld.bodies[0]), t.body_index(ld.bodies[1])
                self.world_point(b0, ld.points[0], f"La{i}")
                self.world_point(b1, ld.points[1], f"Lb{i}")
                self.w(f"Ldx{i} = Lb{i}x - La{i}x; Ldy{i} = Lb{i}y - La{i}y")
                self.w(f"Ll{i} = np.sqrt(Ldx{i}*Ldx{i} + Ldy{i}*Ldy{i})")
                self.w(f"Lnx{i} = Ldx{i}/Ll{i}; Lny{i} = Ldy{i}/Ll{i}")
                self.w(f"Lld{i} = (Lb{i}vx - La{i}vx)*Lnx{i} + (Lb{i}vy - La{i}vy)*Lny{i}")
                k_, l0, c_ = (self.P(f"loads.{i}.stiffness"), self.P(f"loads.{i}.free_length"),
                              self.P(f"loads.{i}.damping"))
                self.w(f"Lf{i} = {fm}*({k_}*(Ll{i} - {l0}) + {c_}*Lld{i})")
                self.w(f"Lfx{i} = Lf{i}*Lnx{i}; Lfy{i} = Lf{i}*Lny{i}")
                self.add_force(b0, f"La{i}x", f"La{i}y", f"Lfx{i}", f"Lfy{i}", coords)
                self.add_force(b1, f"Lb{i}x", f"Lb{i}y", f"(-Lfx{i})", f"(-Lfy{i})", coords)
                if observe:
                    self.w(f"Vpot += 0.5*{k_}*(Ll{i} - {l0})**2")
                    self.w(f"Pload -= {c_}*Lld{i}*Lld{i}")

    def clearance_force(self, ci: int, jn: str, coords: list[int], observe: bool):
        sc, t = self.scene, self.topo
        j = sc.joints[jn]
        bj, bb = t.body_index(j.bodies[0]), t.body_index(j.bodies[1])
        pre = f"joints.{jn}."
        self.world_point(bj, j.points[0], f"A{ci}")
        self.world_point(bb, j.points[1], f"B{ci}")
        self.w(f"ex{ci} = A{ci}x - B{ci}x; ey{ci} = A{ci}y - B{ci}y")
        self.w(f"dex{ci} = A{ci}vx - B{ci}vx; dey{ci} = A{ci}vy - B{ci}vy")
        self.w(f"ecc{ci} = np.sqrt(ex{ci}*ex{ci} + ey{ci}*ey{ci})")
        self.w(f"pen{ci} = ecc{ci} - {self.P(pre + 'clearance')}")
        self.w(f"Fn{ci} = 0.0; Ft{ci} = 0.0; vt{ci} = 0.0; ddot{ci} = 0.0")
        hyb = ci in self.Z.mode
        if hyb:
            self.w(f"nx{ci} = 1.0; ny{ci} = 0.0")
        self.w(f"if ecc{ci} > 0.0:")
        self.ind += 1
        self.w(f"nx{ci} = ex{ci}/ecc{ci}; ny{ci} = ey{ci}/ecc{ci}")
        self.w(f"ddot{ci} = dex{ci}*nx{ci} + dey{ci}*ny{ci}")
        fr = friction_present(j)
        if fr or observe:
            wj = "0.0" if bj == GROUND else f"w{bj}"
            wb = "0.0" if bb == GROUND else f"w{bb}"
            rj = self.P(pre + "journal_radius")
            self.w(f"vt{ci} = slip_velocity(dex{ci}, dey{ci}, nx{ci}, ny{ci}, {wj}, {wb}, {rj}, "
                   f"{rj} + {self.P(pre + 'clearance')})")
        self.ind -= 1
        if hyb:
            self.stick_row(ci, jn, coords)
        law = law_of(j)
        if law.jump_at_onset:
            # contact is a mode (z[ci] > 0 from the located onset to the located separation): the
            # jump C*ddot0 of seed eq. 11 happens at the event, never inside a step; in contact mode
            # hertz_damped_contact() is the smooth extension for trial points past the boundary
            self.w(f"if z[{ci}] > 0.0:")
        else:
            self.w(f"if pen{ci} > 0.0:")
        self.ind += 1
        self.w(f"K = {self.P(pre + 'contact.stiffness')}; nexp = {self.P(pre + 'contact.exponent')}")
        if law.onset_velocity:
            self.w(f"vm = z[{ci}] if z[{ci}] > 0.0 else {self.P(pre + 'contact.min_approach_velocity')}")
        args = law_arguments(self, law, pre, "K, nexp", "vm")
        # a law with a jump at onset runs its contact-mode force (hertz_damped keeps C*ddot at
        # pen <= 0: the onset state is pen = 0 only to the root tolerance), nld.laws.law
        force = law.mode_force if law.jump_at_onset else law.force
        self.w(f"Fn{ci} = {force.__name__}(pen{ci}, ddot{ci}, {args})")
        if fr:
            f = j.friction
            if hyb:
                # slip: the sign is the mode's (coulomb() at vt = +-1); stick: the multiplier of the
                # stick row, set after the solve; free: no friction
                self.w(f"md{ci} = z[{self.Z.mode[ci]}]")
                self.w(f"if md{ci} == 1.0 or md{ci} == -1.0:")
                self.w(f"    Ft{ci} = coulomb(md{ci}, Fn{ci}, {self.P(pre + 'friction.mu')})")
            elif f.law == "ambrosio" and f.mu > 0:
                self.w(f"Ft{ci} = ambrosio(vt{ci}, Fn{ci}, {self.P(pre + 'friction.mu')}, "
                       f"{self.P(pre + 'friction.v0')}, {self.P(pre + 'friction.v1')})")
            if f.tangential_damping > 0:
                self.w(f"Ft{ci} += viscous(vt{ci}, {self.P(pre + 'friction.tangential_damping')})")
            # force on the journal at its contact point, opposite on the bearing at its contact point
            self.w(f"Fx{ci} = -Fn{ci}*nx{ci} + Ft{ci}*ny{ci}; Fy{ci} = -Fn{ci}*ny{ci} - Ft{ci}*nx{ci}")
            rj = self.P(pre + "journal_radius")
            self.w(f"QAx{ci} = A{ci}x + {rj}*nx{ci}; QAy{ci} = A{ci}y + {rj}*ny{ci}")
            self.w(f"rb{ci} = {rj} + {self.P(pre + 'clearance')}")
            self.w(f"QBx{ci} = B{ci}x + rb{ci}*nx{ci}; QBy{ci} = B{ci}y + rb{ci}*ny{ci}")
            self.add_force(bj, f"QAx{ci}", f"QAy{ci}", f"Fx{ci}", f"Fy{ci}", coords)
            self.add_force(bb, f"QBx{ci}", f"QBy{ci}", f"(-Fx{ci})", f"(-Fy{ci})", coords)
        else:
            self.w(f"Fx{ci} = -Fn{ci}*nx{ci}; Fy{ci} = -Fn{ci}*ny{ci}")
            self.add_force(bj, f"A{ci}x", f"A{ci}y", f"Fx{ci}", f"Fy{ci}", coords)
            self.add_force(bb, f"B{ci}x", f"B{ci}y", f"(-Fx{ci})", f"(-Fy{ci})", coords)
        if observe:
            self.w(f"Vpot += contact_energy(pen{ci}, K, nexp)")
            # power of the non-conservative part of the contact (damping, friction) on the system
            self.w(f"Pload += -(Fn{ci} - elastic_force(pen{ci}, K, nexp))*ddot{ci} - Ft{ci}*vt{ci}")
        self.ind -= 1

    def stick_row(self, ci: int, jn: str, coords: list[int]):
        """Jacobian Jt{ci}_{k} = d vt / d qd_k and bias bt{ci} = d vt/dt at zero accelerations of
        the joint's slip velocity vt = t.(vA - vB) + w_j R_j - w_b R_b (friction.slip_velocity,
        t = (-ny, nx)): the acceleration-level stick constraint Jt qdd + bt = 0 (docs/contact-laws.md,
        "Modes"). d t/dt = (-dny, dnx) with dn/dt = (de/dt - n ddot)/|e|."""
        sc, t = self.scene, self.topo
        j = sc.joints[jn]
        bj, bb = t.body_index(j.bodies[0]), t.body_index(j.bodies[1])
        pre = f"joints.{jn}."
        rj = self.P(pre + "journal_radius")
        rb = f"({rj} + {self.P(pre + 'clearance')})"
        # only a sticking joint needs its row: zero otherwise (the Schur complement and the augmented
        # solve read the row only in stick mode; zeros keep every variable defined on every path)
        self.w(f"bt{ci} = 0.0; " + "; ".join(f"Jt{ci}_{k} = 0.0" for k in coords))
        self.w(f"if z[{self.Z.mode[ci]}] == 2.0:")
        self.ind += 1
        acc = {}
        for b, tag in ((bj, f"A{ci}"), (bb, f"B{ci}")):
            if b == GROUND:
                acc[tag] = ("0.0", "0.0", "0.0")
            else:
                self.w(f"{tag}ax = ax{b} - al{b}*{tag}dy - w{b}*w{b}*{tag}dx; "
                       f"{tag}ay = ay{b} + al{b}*{tag}dx - w{b}*w{b}*{tag}dy")
                acc[tag] = (f"{tag}ax", f"{tag}ay", f"al{b}")
        (aax, aay, aal), (bax, bay, bal) = acc[f"A{ci}"], acc[f"B{ci}"]
        self.w(f"dnx{ci} = 0.0; dny{ci} = 0.0")
        self.w(f"if ecc{ci} > 0.0:")
        self.w(f"    dnx{ci} = (dex{ci} - nx{ci}*ddot{ci})/ecc{ci}; dny{ci} = (dey{ci} - ny{ci}*ddot{ci})/ecc{ci}")
        self.w(f"bt{ci} = -dny{ci}*dex{ci} + dnx{ci}*dey{ci} - ny{ci}*({aax} - {bax}) + nx{ci}*({aay} - {bay}) "
               f"+ {rj}*{aal} - {rb}*{bal}")
        anc_j = set(t.ancestors(bj)) if bj != GROUND else set()
        anc_b = set(t.ancestors(bb)) if bb != GROUND else set()
        for k in coords:
            terms = []
            for anc, tag, sign, R in ((anc_j, f"A{ci}", "+", rj), (anc_b, f"B{ci}", "-", rb)):
                if k not in anc:
                    continue
                jx, jy, jt = self.jac(k, f"{tag}x", f"{tag}y")
                terms.append(f"{sign}(-ny{ci}*{jx} + nx{ci}*{jy}" + (f" + {R}" if jt == "1.0" else "") + ")")
            self.w(f"Jt{ci}_{k} = {' '.join(terms) if terms else '0.0'}")
        self.ind -= 1

    # --- mass matrix and bias ------------------------------------------------------------
    def mass_matrix(self, coords: list[int], arr: bool):
        """M{a}_{b} (a <= b) or Mm[ia, ib] and bias-corrected Q{k} -= h_k for the given coordinates."""
        t = self.topo
        pos = {k: i for i, k in enumerate(coords)}
        acc: dict[tuple[int, int], list[str]] = {}
        for b in t.order:
            anc = [k for k in t.ancestors(b) if k in pos]
            if not anc:
                continue
            m = self.P(f"bodies.{t.body_names[b]}.mass")
            I_ = self.P(f"bodies.{t.body_names[b]}.inertia")
            for k in anc:
                jx, jy, jt = self.jac(k, f"x{b}", f"y{b}")
                self.w(f"jx{b}_{k} = {jx}; jy{b}_{k} = {jy}")
                # bias: Q_k -= m a_bias . J_k + I al_bias Jt_k
                term = f"{m}*(ax{b}*jx{b}_{k} + ay{b}*jy{b}_{k})"
                if jt == "1.0":
                    term += f" + {I_}*al{b}"
                self.w(f"Q{k} -= {term}")
            for ia, k in enumerate(anc):
                for l in anc[ia:]:
                    a, c = sorted((pos[k], pos[l]))
                    kk, ll = coords[a], coords[c]
                    _, _, jtk = self.jac(kk, "", "")
                    _, _, jtl = self.jac(ll, "", "")
                    s = f"{m}*(jx{b}_{kk}*jx{b}_{ll} + jy{b}_{kk}*jy{b}_{ll})"
                    if jtk == "1.0" and jtl == "1.0":
                        s += f" + {I_}"
                    acc.setdefault((a, c), []).append(s)
        if t.crank_coord is not None and t.crank_coord in pos and self.scene.driver.mode == "torque":
            a = pos[t.crank_coord]
            acc.setdefault((a, a), []).append(self.P("driver.inertia"))
        n = len(coords)
        for a in range(n):
            for c in range(a, n):
                expr = " + ".join(acc.get((a, c), ["0.0"]))
                if arr:
                    self.w(f"Mm[{a}, {c}] = {expr}")
                    if c != a:
                        self.w(f"Mm[{c}, {a}] = Mm[{a}, {c}]")
                else:
                    self.w(f"M{a}_{c} = {expr}")

    def ldl_solve(self, n: int, rhs_names: list[str], out_names: list[str]):
        """Unrolled LDL^T solve of M x = b (M symmetric positive definite, scalars M{a}_{c})."""
        self.ldl_factor(n)
        self.ldl_subst(n, rhs_names, out_names)

    def ldl_factor(self, n: int, M: str = "M", L: str = "L", D: str = "D"):
        """Unrolled LDL^T factorisation of the symmetric positive definite {M}{a}_{c} (a <= c):
        scalars {D}{j} and {L}{i}_{j} (i > j)."""
        for j in range(n):
            s = f"{M}{j}_{j}" + "".join(f" - {L}{j}_{k}*{L}{j}_{k}*{D}{k}" for k in range(j))
            self.w(f"{D}{j} = {s}")
            for i in range(j + 1, n):
                s = f"{M}{j}_{i}" + "".join(f" - {L}{i}_{k}*{L}{j}_{k}*{D}{k}" for k in range(j))
                self.w(f"{L}{i}_{j} = ({s})/{D}{j}")

    def ldl_subst(self, n: int, rhs_names: list[str], out_names: list[str], L: str = "L", D: str = "D",
                  tmp: str = "zz"):
        """Forward/backward substitution with the factors of ldl_factor: out = M^-1 rhs."""
        for i in range(n):
            s = rhs_names[i] + "".join(f" - {L}{i}_{k}*{tmp}{k}" for k in range(i))
            self.w(f"{tmp}{i} = {s}")
        for i in range(n):
            self.w(f"{tmp}{i} /= {D}{i}")
        for i in reversed(range(n)):
            s = f"{tmp}{i}" + "".join(f" - {L}{k}_{i}*{out_names[k]}" for k in range(i + 1, n))
            self.w(f"{out_names[i]} = {s}")

    def stick_schur(self, S: list[int]):
        """Accelerations of a tree (no ideal loop) with hybrid Coulomb joints in stick mode, by the
        Schur complement on the unrolled LDL^T of M (already factored; qdd{k} holds the free
        solution x0 = M^-1 Q):

            M qdd + sum_h Jt_h^T lam_h = Q,   Jt_h qdd + bt_h = 0  (each sticking joint h)
            Y_h = M^-1 Jt_h^T,   (Jt_a Y_b) lam = bt_a + Jt_a x0,   qdd = x0 - sum_h Y_h lam_h.

        A joint not in stick mode gets an identity row (lam = 0, its Y = 0), so the Schur matrix
        (size = the number of hybrid joints, 1 or 2 in the scenes) stays symmetric positive
        definite and is solved by an unrolled LDL^T too: no array, no allocation. With no joint
        in stick mode nothing of this runs. lam_h is the stick force F_t along the slip direction
        (friction.py's sign: applied opposite on the journal), as the augmented solve's
        multiplier (docs/contact-laws.md, "Modes")."""
        ZL = self.Z
        hyb = ZL.hybrid
        n, nh = len(S), len(hyb)
        stick = [f"z[{ZL.mode[ci]}] == 2.0" for ci in hyb]
        self.w("if " + " or ".join(stick) + ":")
        self.ind += 1
        for h, ci in enumerate(hyb):
            self.w("; ".join(f"Y{h}_{k} = 0.0" for k in S) + f"; Sc{h}_{h} = 1.0; rs{h} = 0.0")
            self.w(f"if {stick[h]}:")
            self.ind += 1
            self.ldl_subst(n, [f"Jt{ci}_{k}" for k in S], [f"Y{h}_{k}" for k in S])
            self.w(f"Sc{h}_{h} = " + " + ".join(f"Jt{ci}_{k}*Y{h}_{k}" for k in S))
            self.w(f"rs{h} = bt{ci} + " + " + ".join(f"Jt{ci}_{k}*qdd{k}" for k in S))
            self.ind -= 1
        for a, ca in enumerate(hyb):
            for b in range(a + 1, nh):      # zero unless both stick: Jt of a free joint is zero, Y too
                self.w(f"Sc{a}_{b} = " + " + ".join(f"Jt{ca}_{k}*Y{b}_{k}" for k in S))
        self.ldl_factor(nh, M="Sc", L="Ls", D="Ds")
        self.ldl_subst(nh, [f"rs{h}" for h in range(nh)], [f"lam_s{h}" for h in range(nh)], L="Ls", D="Ds",
                       tmp="zs")
        for k in S:
            self.w(f"qdd{k} -= " + " + ".join(f"Y{h}_{k}*lam_s{h}" for h in range(nh)))
        for h, ci in enumerate(hyb):
            self.w(f"if {stick[h]}:")
            self.w(f"    Ft{ci} = lam_s{h}")
        self.ind -= 1

    # --- loops of ideal joints -------------------------------------------------------
    def cut_terms(self, coords: list[int], bias: bool):
        """Residual R{r}, Jacobian entries Jc{r}_{k} (k in coords), bias ab{r} of the cut constraints."""
        t, sc = self.topo, self.scene
        for c, jn in enumerate(t.cuts):
            j = sc.joints[jn]
            bi, bj = t.body_index(j.bodies[0]), t.body_index(j.bodies[1])
            self.world_point(bi, j.points[0], f"Ca{c}", vel=False, acc=bias)
            self.world_point(bj, j.points[1], f"Cb{c}", vel=False, acc=bias)
            self.w(f"R{2 * c} = Ca{c}x - Cb{c}x; R{2 * c + 1} = Ca{c}y - Cb{c}y")
            anc_i, anc_j = set(t.ancestors(bi)) if bi != GROUND else set(), set(t.ancestors(bj)) if bj != GROUND else set()
            for k in coords:
                ex, ey = [], []
                if k in anc_i:
                    jx, jy, _ = self.jac(k, f"Ca{c}x", f"Ca{c}y")
                    ex.append(jx); ey.append(jy)
                if k in anc_j:
                    jx, jy, _ = self.jac(k, f"Cb{c}x", f"Cb{c}y")
                    ex.append(f"-{jx}"); ey.append(f"-{jy}")
                self.w(f"Jc{2 * c}_{k} = {' + '.join(ex) if ex else '0.0'}; "
                       f"Jc{2 * c + 1}_{k} = {' + '.join(ey) if ey else '0.0'}")
            if bias:
                self.w(f"ab{2 * c} = Ca{c}ax - Cb{c}ax; ab{2 * c + 1} = Ca{c}ay - Cb{c}ay")

    def newton_loops(self):
        """Solve the cut constraints for the dependent coordinates, warm-started from z."""
        t = self.topo
        m, D = 2 * len(t.cuts), t.dependent
        z0 = len(t.clearance)
        all_k = list(range(len(t.coords)))
        for i, d in enumerate(D):
            self.w(f"q{d} = z[{z0 + i}]")
        self.w(f"Jd = np.empty(({m}, {m})); Rr = np.empty({m})")
        self.w("nerr = 1.0")
        self.w("for it in range(60):")
        self.ind += 1
        self.positions()
        self.cut_terms(all_k, bias=False)
        for r in range(m):
            self.w(f"Rr[{r}] = R{r}")
            for i, d in enumerate(D):
                self.w(f"Jd[{r}, {i}] = Jc{r}_{d}")
        self.w("dq = np.linalg.solve(Jd, Rr)")
        self.w("nerr = 0.0")
        for i, d in enumerate(D):
            self.w(f"q{d} -= dq[{i}]")
            self.w(f"nerr = max(nerr, abs(dq[{i}]))")
        self.w("if nerr < 1e-13:")
        self.w("    break")
        self.ind -= 1
        for i, d in enumerate(D):
            self.w(f"z[{z0 + i}] = q{d}")
        self.positions()
        self.cut_terms(all_k, bias=False)
        # dependent velocities: Phi_D qd_D = -sum_{k not in D} Phi_k qd_k
        for r in range(m):
            self.w(f"Rr[{r}] = -(" + " + ".join([f"Jc{r}_{k}*qd{k}" for k in all_k if k not in D] or ["0.0"]) + ")")
            for i, d in enumerate(D):
                self.w(f"Jd[{r}, {i}] = Jc{r}_{d}")
        self.w("vq = np.linalg.solve(Jd, Rr)")
        for i, d in enumerate(D):
            self.w(f"qd{d} = vq[{i}]")
        self.w("if nerr > 1e-9 or not np.isfinite(nerr):")
        self.w("    newton_failed = True")
        self.w("else:")
        self.w("    newton_failed = False")


def law_arguments(E, law: ContactLaw, pre: str, head: str, v_minus: str) -> str:
    """The argument list of a law's force after (delta, ddot): ``head`` (K, n) and its extras."""
    names = {"restitution": E.P(pre + "contact.restitution"), "damping": E.P(pre + "contact.damping"),
             "v_minus": v_minus}
    return ", ".join([head] + [names[e] for e in law.extra])


def _law_imports(scene: Scene, topo: Topology) -> list[str]:
    """One import line per contact law the scene uses (and nothing for the others)."""
    laws = sorted({scene.joints[jn].contact.law for jn in topo.clearance})
    return [f"from {f.__module__} import {f.__name__}" for nm in laws for f in contact_law(nm).functions()]


def _header(scene: Scene, topo: Topology) -> list[str]:
    return [
        "# generated by nld.kernel.codegen: do not edit",
        "import numpy as np",
        "from numba import njit",
        *_law_imports(scene, topo),
        "from nld.laws.elastic import elastic_force, contact_energy",
        "from nld.laws.friction import coulomb, ambrosio, viscous, slip_velocity",
        "from nld.kernel.support import periodic_table",
        "",
    ]


def columns(scene: Scene, topo: Topology) -> list[str]:
    cols = ["driver.angle", "driver.speed", "driver.torque"]
    for b in topo.body_names:
        cols += [f"{b}.{s}" for s in ("x", "y", "theta", "vx", "vy", "omega", "ax", "ay", "alpha")]
    for jn in topo.clearance:
        cols += [f"{jn}.{s}" for s in ("ex", "ey", "eccentricity", "penetration", "penetration_rate",
                                       "Fn", "Ft", "slip", "contact")]
    cols += ["energy.kinetic", "energy.potential", "energy.total", "power.driver", "power.loads", "newton.ok"]
    return cols


def event_count(scene: Scene, topo: Topology) -> int:
    return ZLayout(scene, topo).n_events


def generate(scene: Scene, topo: Topology, layout) -> str:
    """Source text of the kernel module for this scene's structure."""
    E = Emitter(scene, topo, layout)
    out = _header(scene, topo)
    t = topo
    loops = bool(t.cuts)
    S = list(t.independent) + list(t.dependent) if loops else list(t.independent)
    crank = t.crank_coord
    speed_mode = crank is not None and crank in t.rheonomic
    S_obs = S + ([crank] if speed_mode else [])
    n_ind = len(t.independent)
    ZL = E.Z
    hyb = ZL.hybrid

    def body(observe: bool):
        """The dynamics' lines (indent 1); E's current lines are left as they were."""
        saved = E.lines, E.ind
        E.lines = []
        E.ind = 1
        E.coords_from_state("obs" if observe else "rhs")
        if loops:
            E.newton_loops()
        else:
            E.positions()
        E.velocities(bias=True)
        coords = S_obs if observe else S
        E.forces(coords, observe)
        if t.crank_coord is not None and scene.driver.mode == "torque":
            E.w(f"Tm = {E.P('driver.torque')} - {E.P('driver.torque_slope')}*(qd{crank} - {E.P('driver.speed')})")
            E.w(f"Q{crank} += Tm")
        n = len(S)
        if not loops:
            E.mass_matrix(coords, arr=False)
            if n:
                E.ldl_solve(n, [f"Q{k}" for k in S], [f"qdd{k}" for k in S])
                if hyb:     # stick rows by the Schur complement on the same factors (stick_schur)
                    E.stick_schur(S)
        else:
            # augmented system [M Phi_q^T; Phi_q 0]: loop closures, then one row per hybrid Coulomb
            # joint: its stick constraint Jt qdd = -bt in stick mode, else lam = 0 (identity row)
            m = 2 * len(t.cuts)
            nh = len(hyb)
            N = n + m + nh
            nn = len(coords)
            E.w(f"Mm = np.empty(({nn}, {nn}))")
            E.mass_matrix(coords, arr=True)
            if loops:
                E.cut_terms(coords, bias=True)
            E.w(f"A = np.zeros(({N}, {N})); bb = np.empty({N})")
            E.w(f"A[:{n}, :{n}] = Mm[:{n}, :{n}]")
            for i, k in enumerate(S):
                E.w(f"bb[{i}] = Q{k}")
                for r in range(m):
                    E.w(f"A[{n + r}, {i}] = Jc{r}_{k}; A[{i}, {n + r}] = Jc{r}_{k}")
            for r in range(m):
                E.w(f"bb[{n + r}] = -ab{r}")
            for h, ci in enumerate(hyb):
                r = n + m + h
                E.w(f"if z[{ZL.mode[ci]}] == 2.0:")
                E.ind += 1
                for i, k in enumerate(S):
                    E.w(f"A[{r}, {i}] = Jt{ci}_{k}; A[{i}, {r}] = Jt{ci}_{k}")
                E.w(f"bb[{r}] = -bt{ci}")
                E.ind -= 1
                E.w("else:")
                E.w(f"    A[{r}, {r}] = 1.0; bb[{r}] = 0.0")
            E.w("sol = np.linalg.solve(A, bb)")
            for i, k in enumerate(S):
                E.w(f"qdd{k} = sol[{i}]")
            for r in range(m):
                E.w(f"lam{r} = sol[{n + r}]")
            for h, ci in enumerate(hyb):
                # the stick force along the slip direction (the sign convention of friction.py:
                # applied opposite on the journal): Q = M qdd + Jt^T Ft
                E.w(f"if z[{ZL.mode[ci]}] == 2.0:")
                E.w(f"    Ft{ci} = sol[{n + m + h}]")
        for k in t.rheonomic:
            E.w(f"qdd{k} = 0.0")
        res = list(E.lines)
        E.lines, E.ind = saved
        return res

    # rhs
    out.append("@njit(cache=True, fastmath=False)")
    i_rhs = len(out)
    out.append("def rhs(t, y, p, z, dy):")
    out += body(False)
    for i, k in enumerate(t.independent):
        out.append(f"    dy[{i}] = qd{k}")
        out.append(f"    dy[{n_ind + i}] = qdd{k}")
    if loops:
        out.append("    if newton_failed:")
        out.append("        dy[0] = np.nan")
    out.append("")
    rhs_src = "\n".join(out[i_rhs:])

    def start_positions():
        """A fresh function body that has every coordinate and body position."""
        E.lines = []
        E.ind = 1
        E.coords_from_state("ev")
        if loops:
            E.newton_loops()
        else:
            E.positions()

    # events: penetration of each clearance joint, load switches, slip/stick of hybrid joints.
    # Positions and velocities only, except the stick margins of joints in stick mode (their stick
    # force is the multiplier of the constrained dynamics: the whole rhs, run only then).
    start_positions()
    need_vel = set(hyb) | set(ZL.clamp)
    if need_vel:
        E.velocities(bias=False)
    for ci, jn in enumerate(t.clearance):
        j = scene.joints[jn]
        E.world_point(t.body_index(j.bodies[0]), j.points[0], f"A{ci}", vel=ci in need_vel)
        E.world_point(t.body_index(j.bodies[1]), j.points[1], f"B{ci}", vel=ci in need_vel)
        E.w(f"g[{ci}] = np.sqrt((A{ci}x - B{ci}x)**2 + (A{ci}y - B{ci}y)**2) - "
            f"{E.P(f'joints.{jn}.clearance')}")
    for i, ld in enumerate(scene.loads):
        if ld.modulation == "crank_halves":
            E.w(f"g[{ZL.ev_load[i]}] = np.sin(q{crank})")
        elif ld.modulation == "angle_threshold":
            E.w(f"g[{ZL.ev_load[i]}] = th{t.body_index(ld.body)} - {E.P(f'loads.{i}.threshold')}")
    for ci in hyb:
        jn = t.clearance[ci]
        j = scene.joints[jn]
        md = f"z[{ZL.mode[ci]}]"
        # slip velocity (as clearance_force computes it), positive while slipping in the mode's
        # direction
        E.w(f"hv{ci} = 1.0")
        E.w(f"if {md} == 1.0 or {md} == -1.0:")
        E.ind += 1
        bj, bb = t.body_index(j.bodies[0]), t.body_index(j.bodies[1])
        rj = E.P(f"joints.{jn}.journal_radius")
        wj = "0.0" if bj == GROUND else f"w{bj}"
        wb = "0.0" if bb == GROUND else f"w{bb}"
        E.w(f"exv = A{ci}x - B{ci}x; eyv = A{ci}y - B{ci}y; eccv = np.sqrt(exv*exv + eyv*eyv)")
        E.w(f"vt{ci} = 0.0")
        E.w("if eccv > 0.0:")
        E.w(f"    vt{ci} = slip_velocity(A{ci}vx - B{ci}vx, A{ci}vy - B{ci}vy, exv/eccv, eyv/eccv, {wj}, {wb}, "
            f"{rj}, {rj} + {E.P(f'joints.{jn}.clearance')})")
        E.w(f"hv{ci} = {md}*(vt{ci} - z[{ZL.vt0[ci]}])")
        E.ind -= 1
        E.w(f"g[{ZL.ev_v[ci]}] = z[{ZL.sig_v[ci]}]*hv{ci}")
        E.w(f"hf{ci} = 1.0")
    if hyb:
        # stick margin mu_s Fn - |Ft|, from the dynamics, only when some joint sticks
        E.w("if " + " or ".join(f"z[{ZL.mode[ci]}] == 2.0" for ci in hyb) + ":")
        E.ind += 1
        E.lines += ["    " * E.ind + ln[4:] for ln in body(False)]
        for ci in hyb:
            jn = t.clearance[ci]
            E.w(f"if z[{ZL.mode[ci]}] == 2.0:")
            E.w(f"    hf{ci} = {E.P(f'joints.{jn}.friction.mu_s')}*Fn{ci} - abs(Ft{ci})")
        E.ind -= 1
        for ci in hyb:
            E.w(f"g[{ZL.ev_f[ci]}] = z[{ZL.sig_f[ci]}]*hf{ci}")
    for ci in ZL.clamp:
        jn = t.clearance[ci]
        pre = f"joints.{jn}."
        # the unclamped force: positive in contact, negative once clamped; 1 (inactive) when free
        # (and then not computed: a free joint's event scan needs its penetration only)
        E.w(f"hc{ci} = 1.0")
        E.w(f"if z[{ci}] != 0.0:")
        E.ind += 1
        E.w(f"exc = A{ci}x - B{ci}x; eyc = A{ci}y - B{ci}y; eccc = np.sqrt(exc*exc + eyc*eyc)")
        E.w(f"ddc = ((A{ci}vx - B{ci}vx)*exc + (A{ci}vy - B{ci}vy)*eyc)/eccc if eccc > 0.0 else 0.0")
        E.w(f"pc = max(eccc - {E.P(pre + 'clearance')}, 0.0)")
        law = law_of(j)
        head = f"{E.P(pre + 'contact.stiffness')}, {E.P(pre + 'contact.exponent')}"
        E.w(f"Fr{ci} = {law.unclamped.__name__}(pc, ddc, {law_arguments(E, law, pre, head, '')})")
        E.w(f"hc{ci} = Fr{ci} if z[{ci}] > 0.0 else -Fr{ci}")
        E.ind -= 1
        E.w(f"g[{ZL.ev_c[ci]}] = z[{ZL.sig_c[ci]}]*hc{ci}")
    out.append("@njit(cache=True)")
    out.append("def events(t, y, p, z, g):")
    out += E.lines + ["    return", ""]
    events_src = "\n".join(["def events(t, y, p, z, g):"] + E.lines + ["    return"])

    def stick_checks(lines_only_if: str):
        """After a tentative stick (mode 2): keep it if |Ft| <= mu_s Fn, else slip in the direction
        of the force (Filippov's rules, docs/contact-laws.md)."""
        for ci in hyb:
            jn = t.clearance[ci]
            md = f"z[{ZL.mode[ci]}]"
            cond = lines_only_if.format(ci=ci, ev_v=ZL.ev_v.get(ci), ev_f=ZL.ev_f.get(ci))
            E.w(f"if {cond}{md} == 2.0:")
            E.ind += 1
            E.w(f"if chk{ci} == 2 or abs(Ft{ci}) > {E.P(f'joints.{jn}.friction.mu_s')}*Fn{ci}:")
            E.w(f"    {md} = 1.0 if Ft{ci} >= 0.0 else -1.0")
            E.w(f"    z[{ZL.vt0[ci]}] = vt{ci}")
            E.ind -= 1

    # on_event: record the approach velocity at contact onset, switch loads and friction modes
    start_positions()
    E.velocities(bias=False)
    for ci in hyb:
        E.w(f"chk{ci} = 0")
    for ci, jn in enumerate(t.clearance):
        j = scene.joints[jn]
        E.w(f"if k == {ci}:")
        E.ind += 1
        E.world_point(t.body_index(j.bodies[0]), j.points[0], f"A{ci}")
        E.world_point(t.body_index(j.bodies[1]), j.points[1], f"B{ci}")
        E.w(f"ex = A{ci}x - B{ci}x; ey = A{ci}y - B{ci}y")
        E.w("ecc = np.sqrt(ex*ex + ey*ey)")
        E.w(f"vn = ((A{ci}vx - B{ci}vx)*ex + (A{ci}vy - B{ci}vy)*ey)/ecc if ecc > 0.0 else 0.0")
        E.w("if direction > 0:")
        E.w(f"    z[{ci}] = max(vn, {E.P(f'joints.{jn}.contact.min_approach_velocity')})")
        E.w("else:")
        E.w(f"    z[{ci}] = 0.0")
        if ci in ZL.mode:
            # onset: slip in the direction of the slip velocity (a tentative stick, checked below,
            # if it is exactly zero); separation: free
            bj, bb = t.body_index(j.bodies[0]), t.body_index(j.bodies[1])
            rj = E.P(f"joints.{jn}.journal_radius")
            wj = "0.0" if bj == GROUND else f"w{bj}"
            wb = "0.0" if bb == GROUND else f"w{bb}"
            E.w("if direction > 0:")
            E.ind += 1
            E.w("nx_ = ex/ecc if ecc > 0.0 else 1.0; ny_ = ey/ecc if ecc > 0.0 else 0.0")
            E.w(f"vt_ = slip_velocity(A{ci}vx - B{ci}vx, A{ci}vy - B{ci}vy, nx_, ny_, {wj}, {wb}, {rj}, "
                f"{rj} + {E.P(f'joints.{jn}.clearance')})")
            E.w(f"z[{ZL.mode[ci]}] = 1.0 if vt_ > 0.0 else (-1.0 if vt_ < 0.0 else 2.0)")
            E.w(f"z[{ZL.vt0[ci]}] = 0.0")
            E.w(f"chk{ci} = 1")
            E.ind -= 1
            E.w("else:")
            E.w(f"    z[{ZL.mode[ci]}] = 0.0")
        E.ind -= 1
    for i, ld in enumerate(scene.loads):
        if ld.modulation in SWITCHED:
            up = "1.0" if ld.modulation == "crank_halves" else "-1.0"
            E.w(f"if k == {ZL.ev_load[i]}:")
            E.w(f"    z[{ZL.load[i]}] = {up} if direction > 0 else -{up}")
    for ci in ZL.clamp:
        E.w(f"if k == {ZL.ev_c[ci]}:")         # hertz_damped: clamped <-> pressing (kink located)
        E.w(f"    z[{ZL.sig_c[ci]}] = 1.0 if direction > 0 else -1.0")
        E.w(f"    z[{ci}] = -z[{ci}]")
    for ci in hyb:
        md = f"z[{ZL.mode[ci]}]"
        E.w(f"if k == {ZL.ev_v[ci]}:")         # slip velocity reached zero: tentative stick
        E.ind += 1
        E.w(f"z[{ZL.sig_v[ci]}] = 1.0 if direction > 0 else -1.0")
        E.w(f"if {md} == 1.0 or {md} == -1.0:")
        E.w(f"    {md} = 2.0")
        E.w(f"    chk{ci} = 1")
        E.ind -= 1
        E.w(f"if k == {ZL.ev_f[ci]}:")         # stick force reached mu_s Fn: slip along the force
        E.ind += 1
        E.w(f"z[{ZL.sig_f[ci]}] = 1.0 if direction > 0 else -1.0")
        E.w(f"if {md} == 2.0:")
        E.w(f"    chk{ci} = 2")
        E.ind -= 1
    if hyb:
        E.w("if " + " or ".join(f"chk{ci} > 0" for ci in hyb) + ":")
        E.ind += 1
        E.lines += ["    " + ln for ln in body(False)]
        stick_checks("chk{ci} > 0 and ")
        E.ind -= 1
    out.append("@njit(cache=True)")
    out.append("def on_event(k, direction, t, y, p, z):")
    out += E.lines + ["    return 0", ""]
    on_event_src = "\n".join(["def on_event(k, direction, t, y, p, z):"] + E.lines
                              + ["    return 0"])

    # init_modes: the discrete state's branches from a continuous state (the start of a run)
    start_positions()
    E.velocities(bias=False)
    for i, ld in enumerate(scene.loads):
        if ld.modulation == "crank_halves":
            # the branch sin(q) >= 0 ... on exactly zero, the side the crank is turning to
            E.w(f"sq = np.sin(q{crank})")
            E.w(f"if sq == 0.0:")
            E.w(f"    sq = qd{crank}*np.cos(q{crank})")
            E.w(f"z[{ZL.load[i]}] = 1.0 if sq >= 0.0 else -1.0")
        elif ld.modulation == "angle_threshold":
            b = t.body_index(ld.body)
            E.w(f"z[{ZL.load[i]}] = 1.0 if th{b} <= {E.P(f'loads.{i}.threshold')} else -1.0")
    for ci, jn in enumerate(t.clearance):
        j = scene.joints[jn]
        law = law_of(j)
        hd = law.jump_at_onset
        if not (hd or ci in ZL.mode):
            continue
        bj, bb = t.body_index(j.bodies[0]), t.body_index(j.bodies[1])
        E.world_point(bj, j.points[0], f"A{ci}")
        E.world_point(bb, j.points[1], f"B{ci}")
        E.w(f"ex = A{ci}x - B{ci}x; ey = A{ci}y - B{ci}y")
        E.w("ecc = np.sqrt(ex*ex + ey*ey)")
        E.w(f"inc = ecc - {E.P(f'joints.{jn}.clearance')} > 0.0")
        if hd:
            pre = f"joints.{jn}."
            E.w(f"ddc = ((A{ci}vx - B{ci}vx)*ex + (A{ci}vy - B{ci}vy)*ey)/ecc if ecc > 0.0 else 0.0")
            head = f"{E.P(pre + 'contact.stiffness')}, {E.P(pre + 'contact.exponent')}"
            E.w(f"Frc = {law.unclamped.__name__}(ecc - {E.P(pre + 'clearance')}, ddc, "
                f"{law_arguments(E, law, pre, head, '')})")
            E.w(f"z[{ci}] = 0.0 if not inc else ({E.P(pre + 'contact.min_approach_velocity')} if Frc > 0.0 "
                f"else -{E.P(pre + 'contact.min_approach_velocity')})")
            E.w(f"z[{ZL.sig_c[ci]}] = 1.0")
        if ci in ZL.mode:
            rj = E.P(f"joints.{jn}.journal_radius")
            wj = "0.0" if bj == GROUND else f"w{bj}"
            wb = "0.0" if bb == GROUND else f"w{bb}"
            E.w("nx_ = ex/ecc if ecc > 0.0 else 1.0; ny_ = ey/ecc if ecc > 0.0 else 0.0")
            E.w(f"vt_ = slip_velocity(A{ci}vx - B{ci}vx, A{ci}vy - B{ci}vy, nx_, ny_, {wj}, {wb}, {rj}, "
                f"{rj} + {E.P(f'joints.{jn}.clearance')})")
            # a slip velocity within round-off of zero (1e-12 of the speeds that make it) is zero
            E.w(f"vs_ = 1e-12*(abs(A{ci}vx - B{ci}vx) + abs(A{ci}vy - B{ci}vy) + abs({wj}*{rj}) + "
                f"abs({wb}*({rj} + {E.P(f'joints.{jn}.clearance')})))")
            E.w(f"z[{ZL.mode[ci]}] = 0.0 if not inc else (1.0 if vt_ > vs_ else (-1.0 if vt_ < -vs_ else 2.0))")
            E.w(f"z[{ZL.sig_v[ci]}] = 1.0; z[{ZL.sig_f[ci]}] = 1.0; z[{ZL.vt0[ci]}] = 0.0")
    if hyb:
        for ci in hyb:
            E.w(f"chk{ci} = 1")
        E.lines += body(False)
        stick_checks("")
    out.append("@njit(cache=True)")
    out.append("def init_modes(t, y, p, z):")
    out += E.lines + ["    return", ""]

    # observe
    out.append("@njit(cache=True)")
    out.append("def observe(t, y, p, z, row):")
    out += body(True)
    cols = columns(scene, topo)
    ci_ = {c: i for i, c in enumerate(cols)}
    E.lines = []
    E.ind = 1
    w = E.w
    # body accelerations a = a_bias + J qdd
    for b in t.order:
        anc = t.ancestors(b)
        ax_terms, ay_terms, al_terms = [f"ax{b}"], [f"ay{b}"], [f"al{b}"]
        for k in anc:
            jx, jy, jt = E.jac(k, f"x{b}", f"y{b}")
            ax_terms.append(f"{jx}*qdd{k}")
            ay_terms.append(f"{jy}*qdd{k}")
            if jt == "1.0":
                al_terms.append(f"qdd{k}")
        name = t.body_names[b]
        w(f"row[{ci_[name + '.x']}] = x{b}; row[{ci_[name + '.y']}] = y{b}; row[{ci_[name + '.theta']}] = th{b}")
        w(f"row[{ci_[name + '.vx']}] = vx{b}; row[{ci_[name + '.vy']}] = vy{b}; row[{ci_[name + '.omega']}] = w{b}")
        w(f"row[{ci_[name + '.ax']}] = {' + '.join(ax_terms)}")
        w(f"row[{ci_[name + '.ay']}] = {' + '.join(ay_terms)}")
        w(f"row[{ci_[name + '.alpha']}] = {' + '.join(al_terms)}")
    for ci, jn in enumerate(t.clearance):
        for s, v in (("ex", f"ex{ci}"), ("ey", f"ey{ci}"), ("eccentricity", f"ecc{ci}"),
                     ("penetration", f"pen{ci}"), ("penetration_rate", f"ddot{ci}"), ("Fn", f"Fn{ci}"),
                     ("Ft", f"Ft{ci}"), ("slip", f"vt{ci}")):
            w(f"row[{ci_[f'{jn}.{s}']}] = {v}")
        w(f"row[{ci_[f'{jn}.contact']}] = 1.0 if pen{ci} > 0.0 else 0.0")
    # kinetic energy
    ke = [f"0.5*{E.P(f'bodies.{t.body_names[b]}.mass')}*(vx{b}*vx{b} + vy{b}*vy{b}) + "
          f"0.5*{E.P(f'bodies.{t.body_names[b]}.inertia')}*w{b}*w{b}" for b in t.order]
    if crank is not None and scene.driver.mode == "torque":
        ke.append(f"0.5*{E.P('driver.inertia')}*qd{crank}*qd{crank}")
    w(f"Tkin = {' + '.join(ke) if ke else '0.0'}")
    if crank is not None:
        w(f"row[{ci_['driver.angle']}] = q{crank}; row[{ci_['driver.speed']}] = qd{crank}")
        if speed_mode:
            terms = []
            if not loops:
                pos = {k: i for i, k in enumerate(S_obs)}
                c = pos[crank]
                for k in S:
                    a, b2 = sorted((pos[k], c))
                    terms.append(f"M{a}_{b2}*qdd{k}")
            else:
                c = len(S)
                for i, k in enumerate(S):
                    terms.append(f"Mm[{c}, {i}]*qdd{k}")
                for r in range(2 * len(t.cuts)):
                    terms.append(f"Jc{r}_{crank}*lam{r}")
            for h, ci in enumerate(hyb):
                terms.append(f"(Jt{ci}_{crank}*Ft{ci} if z[{ZL.mode[ci]}] == 2.0 else 0.0)")
            w(f"tau = {' + '.join(terms) if terms else '0.0'} - Q{crank}")
        else:
            w("tau = Tm")
        w(f"row[{ci_['driver.torque']}] = tau")
        w(f"row[{ci_['power.driver']}] = tau*qd{crank}")
    else:
        w(f"row[{ci_['driver.angle']}] = np.nan; row[{ci_['driver.speed']}] = np.nan")
        w(f"row[{ci_['driver.torque']}] = 0.0; row[{ci_['power.driver']}] = 0.0")
    w(f"row[{ci_['energy.kinetic']}] = Tkin; row[{ci_['energy.potential']}] = Vpot")
    w(f"row[{ci_['energy.total']}] = Tkin + Vpot; row[{ci_['power.loads']}] = Pload")
    w(f"row[{ci_['newton.ok']}] = {'0.0 if newton_failed else 1.0' if loops else '1.0'}")
    out += E.lines + [""]
    out += [
        "@njit(cache=True)",
        "def observe_all(ts, Y, Z, n, p, rows):",
        "    for i in range(n):",
        "        zz = Z[i].copy()",
        "        observe(ts[i], Y[i], p, zz, rows[i])",
        "",
        "",
    ]
    # one solve function per native method (nld.integrators.NATIVE): the shared integrator,
    # compiled once per machine, called with this kernel's functions as first-class function
    # arguments (nld.integrators.core); nothing of the integrator is compiled per kernel
    from nld.integrators import NATIVE
    out += ["from nld.integrators import bind as _bind", ""]
    for module, fn, wrapper in NATIVE.values():
        out += [f"{wrapper} = _bind({fn!r}, rhs, events, on_event)", ""]
    try:
        out += tangent_source(rhs_src, events_src, on_event_src)
    except (ValueError, SyntaxError) as e:     # nld.kernel.autodiff.AutodiffError is a ValueError
        # no tangent functions for this kernel: nld.systems.tangent falls back on finite differences
        out += [f"TANGENT_UNAVAILABLE = {' '.join(str(e).split())!r}", ""]
    return "\n".join(out) + "\n"


def tangent_source(rhs_src: str, events_src: str, on_event_src: str) -> list[str]:
    """The tangent (variational) functions of a kernel, by forward differentiation of its
    generated rhs, events and on_event (nld.kernel.autodiff), and the cached tangent integrator.

    rhs_jvp(t, y, p, z, dy, t__d, y__d, z__d, dy__d): dy = f, dy__d = f_t t__d + f_y y__d + f_z z__d
    events_jvp(t, y, p, z, g, t__d, y__d, z__d, g__d): the same for the event functions
    on_event_jvp(k, direction, t, y, p, z, t__d, y__d, z__d): the reset of z and of its tangent
    (z__d updated in place: D_t R t__d + D_y R y__d + D_z R z__d)."""
    from nld.laws import elastic, friction
    from nld.kernel import support as kernel_support
    from nld.kernel.autodiff import Registry, function_source, jvp_source
    known = {nm: function_source(getattr(mod, nm)) for mod, names in (
        (elastic, ("elastic_force", "contact_energy")),
        (friction, ("coulomb", "ambrosio", "viscous", "slip_velocity")),
        (kernel_support, ("periodic_table",))) for nm in names}
    known.update({f.__name__: function_source(f) for nm in contact_laws() for f in contact_law(nm).functions()})
    reg = Registry(known, "@njit(cache=True, inline='always')")
    dec = "@njit(cache=True)"
    fns = [jvp_source(rhs_src, name="rhs_jvp", active=["t", "y", "z"], outputs=["dy"],
                      frozen=["z"], known=known, registry=reg),
           jvp_source(events_src, name="events_jvp", active=["t", "y", "z"], outputs=["g"],
                      frozen=["z"], known=known, registry=reg),
           jvp_source(on_event_src, name="on_event_jvp", active=["t", "y", "z"], outputs=["z"],
                      known=known, registry=reg)]
    out = ["# ---- tangent dynamics (generated by nld.kernel.autodiff from the functions above)", ""]
    for src in reg.sources.values():
        out += src.splitlines() + [""]
    for src in fns:
        out += [dec] + src.splitlines() + [""]
    out += [
        "from nld.integrators.tangent import bind_tangent as _bind_tangent",
        "",
        "solve_tangent = _bind_tangent(rhs, rhs_jvp, events, events_jvp, on_event, on_event_jvp)",
        "",
    ]
    return out
