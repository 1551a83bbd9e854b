"""Topology of a scene: spanning tree of ideal joints, minimal coordinates, loop cuts.

The formulation (docs/formulation.md): ideal joints (zero clearance) are kinematic edges between
bodies; clearance joints are force elements, not edges. A spanning tree of the ideal joints, rooted at
the ground, gives relative (joint) coordinates:

* the driver joint: the crank angle (prescribed in speed mode, a state in torque mode);
* an ideal revolute joint: the child's angle relative to its parent, phi = theta_c - theta_p (rad);
* an ideal prismatic joint: the slide s along the guide (m);
* a body (or group of bodies) not joined to the ground by ideal joints: a floating root with
  absolute x, y (m) and theta (rad).

Ideal revolute joints left out of the tree close loops; each adds two position constraints that the
kernel solves exactly (Newton) for dependent coordinates (coordinate partitioning). When every loop is
cut by a clearance joint there is no constraint: the equations of motion are a plain ODE.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nld.errors import SceneError
from nld.model.scene_model import Scene

GROUND = -1


@dataclass
class Coord:
    """One generalised coordinate of the tree."""
    kind: str          # "crank" | "rev" | "pri" | "fx" | "fy" | "fth"
    body: int          # the body whose inbound joint this coordinate describes
    joint: str         # joint name ("" for a floating root)
    label: str         # column label, e.g. "rod.phi"


@dataclass
class TreeEdge:
    """Inbound joint of a body in the spanning tree."""
    kind: str          # "crank" | "rev" | "pri" | "free"
    joint: str
    parent: int        # body index or GROUND
    parent_point: str  # point name on the parent (ground point for GROUND)
    child_point: str   # point name on the child
    coords: list[int] = field(default_factory=list)   # coordinate indices (3 for free)
    angle_offset: float = 0.0   # prismatic: theta_child - theta_parent (rad), fixed


@dataclass
class Topology:
    body_names: list[str]
    edges: list[TreeEdge]                 # one per body, same order as body_names
    order: list[int]                      # bodies in parent-before-child order
    coords: list[Coord]
    cuts: list[str]                       # ideal revolute joints that close loops
    clearance: list[str]                  # clearance joints (force elements)
    crank_body: int | None
    crank_coord: int | None
    rheonomic: list[int]                  # coordinates prescribed in time (speed-driven crank)
    dependent: list[int] = field(default_factory=list)    # solved from the loop constraints
    independent: list[int] = field(default_factory=list)  # ODE states

    def ancestors(self, b: int) -> list[int]:
        """Coordinates that move body b (its inbound joint and every joint above it)."""
        out: list[int] = []
        while b != GROUND:
            e = self.edges[b]
            out.extend(e.coords)
            b = e.parent
        return out

    def body_index(self, name: str) -> int:
        return GROUND if name == "ground" else self.body_names.index(name)

    @property
    def n_dof(self) -> int:
        return len(self.independent)


def build_topology(scene: Scene) -> Topology:
    names = list(scene.bodies)
    idx = {n: i for i, n in enumerate(names)}
    node = lambda n: 0 if n == "ground" else idx[n] + 1  # noqa: E731

    parent_uf = list(range(len(names) + 1))

    def find(a):
        while parent_uf[a] != a:
            parent_uf[a] = parent_uf[parent_uf[a]]
            a = parent_uf[a]
        return a

    driver = scene.driver.joint if scene.driver is not None else None
    ideal = [j for j in scene.joints.values() if not j.has_clearance]
    # priority: driver joint, prismatic joints, then revolutes (cuts are then revolutes)
    ideal.sort(key=lambda j: (0 if j.name == driver else (1 if j.type == "prismatic" else 2)))
    tree_joints, cuts = [], []
    for j in ideal:
        a, b = find(node(j.bodies[0])), find(node(j.bodies[1]))
        if a == b:
            if j.type == "prismatic":
                raise SceneError(f"joints.{j.name}.type", j.type,
                                 "a prismatic joint that closes a loop of ideal joints is not supported; "
                                 "make a revolute joint of that loop the last one closed")
            cuts.append(j.name)
        else:
            parent_uf[a] = b
            tree_joints.append(j)

    # orient the tree by breadth-first search from the ground, then from floating roots
    adj: dict[int, list] = {i: [] for i in range(len(names) + 1)}
    for j in tree_joints:
        adj[node(j.bodies[0])].append((j, node(j.bodies[1])))
        adj[node(j.bodies[1])].append((j, node(j.bodies[0])))
    edges: list[TreeEdge | None] = [None] * len(names)
    order: list[int] = []
    coords: list[Coord] = []
    crank_body = crank_coord = None
    seen = {0}
    pending_roots = list(range(1, len(names) + 1))

    def visit(start):
        q = [start]
        while q:
            u = q.pop(0)
            for j, v in adj[u]:
                if v in seen:
                    continue
                seen.add(v)
                child = v - 1
                pname_parent = j.points[0] if node(j.bodies[0]) == u else j.points[1]
                pname_child = j.points[1] if node(j.bodies[1]) == v else j.points[0]
                if j.type == "prismatic":
                    if node(j.bodies[0]) != u:
                        raise SceneError(f"joints.{j.name}.bodies", list(j.bodies),
                                         "the guide body (first) must be nearer the ground than the slider "
                                         "in the tree of ideal joints")
                    kind = "pri"
                elif j.name == driver:
                    if u != 0:
                        raise SceneError("driver.joint", j.name, "the driver joint must join a body to the ground")
                    kind = "crank"
                else:
                    kind = "rev"
                e = TreeEdge(kind, j.name, u - 1 if u else GROUND, pname_parent, pname_child)
                ci = len(coords)
                coords.append(Coord(kind, child, j.name,
                                    f"{names[child]}.{'s' if kind == 'pri' else 'phi'}"))
                e.coords = [ci]
                if kind == "pri":
                    pa = scene.bodies[names[u - 1]].angle0 if u else 0.0
                    e.angle_offset = scene.bodies[names[child]].angle0 - pa
                if kind == "crank":
                    nonlocal_crank[0] = child
                    nonlocal_crank[1] = ci
                edges[child] = e
                order.append(child)
                q.append(v)

    nonlocal_crank = [None, None]
    visit(0)
    for r in pending_roots:
        if r in seen:
            continue
        seen.add(r)
        b = r - 1
        e = TreeEdge("free", "", GROUND, "", "")
        ci = len(coords)
        coords.extend([Coord("fx", b, "", f"{names[b]}.x"), Coord("fy", b, "", f"{names[b]}.y"),
                       Coord("fth", b, "", f"{names[b]}.theta")])
        e.coords = [ci, ci + 1, ci + 2]
        edges[b] = e
        order.append(b)
        visit(r)
    crank_body, crank_coord = nonlocal_crank

    rheonomic = []
    if scene.driver is not None and scene.driver.mode == "speed" and crank_coord is not None:
        rheonomic = [crank_coord]
    clearance = [j.name for j in scene.joints.values() if j.has_clearance]
    topo = Topology(names, edges, order, coords, cuts, clearance, crank_body, crank_coord, rheonomic)
    return topo


def partition(topo: Topology, phi_q: np.ndarray) -> None:
    """Choose dependent coordinates for the loop constraints (coordinate partitioning).

    phi_q: constraint Jacobian (m x n_coords) at the assembled configuration. Dependent columns are
    picked by Gaussian elimination with full column pivoting among the non-prescribed coordinates,
    preferring joint angles over the crank (the crank stays independent when it is a state).
    """
    n = len(topo.coords)
    free = [k for k in range(n) if k not in topo.rheonomic]
    m = phi_q.shape[0]
    if m == 0:
        topo.dependent, topo.independent = [], free
        return
    # candidates: crank last so that it stays independent if possible
    cand = [k for k in free if k != topo.crank_coord] + ([topo.crank_coord] if topo.crank_coord in free else [])
    A = phi_q.astype(float).copy()
    dep: list[int] = []
    rows = list(range(m))
    for _ in range(m):
        best, bk, br = 0.0, None, None
        for k in cand:
            if k in dep:
                continue
            for r in rows:
                if abs(A[r, k]) > best * 1.0000001 + 1e-14:
                    best, bk, br = abs(A[r, k]), k, r
        if bk is None or best < 1e-10:
            raise SceneError("joints", topo.cuts, "the loop constraints are redundant or singular at the "
                             "assembled configuration (check the geometry and the angle0 hints)")
        dep.append(bk)
        rows.remove(br)
        piv = A[br].copy()
        for r in rows:
            A[r] -= A[r, bk] / piv[bk] * piv
    topo.dependent = sorted(dep)
    topo.independent = [k for k in free if k not in dep]
