"""Initial configuration of a scene in its minimal (tree) coordinates.

The mechanism is assembled with every joint closed (clearance joints centred: journal centre on the
bearing centre), by Newton in absolute coordinates (nld.model.ideal.assemble), and its velocities are the
ideal-joint velocities. This is the usual start of clearance-joint simulations (Flores & Ambrosio 2004).
The absolute poses are then mapped to the tree coordinates of topology.py.
"""
from __future__ import annotations

import math

import numpy as np

from nld.model.scene_model import Scene
from nld.model.topology import GROUND, Topology


def world_point(scene: Scene, names, poses, vels, body: int, pname: str):
    """World position and velocity of a named point of a body (or the ground)."""
    if body == GROUND:
        x, y = scene.ground_points[pname]
        return np.array([x, y]), np.zeros(2)
    bx, by = scene.bodies[names[body]].points[pname]
    x, y, th = poses[body]
    vx, vy, w = vels[body]
    c, s = math.cos(th), math.sin(th)
    d = np.array([c * bx - s * by, s * bx + c * by])
    return np.array([x, y]) + d, np.array([vx - w * d[1], vy + w * d[0]])


def _guide_direction(joint, parent_angle: float) -> np.ndarray:
    """World unit vector of a prismatic joint's guide on a parent turned by parent_angle (rad)."""
    ax = np.asarray(joint.axis, float) / math.hypot(*joint.axis)
    c, s = math.cos(parent_angle), math.sin(parent_angle)
    return np.array([c * ax[0] - s * ax[1], s * ax[0] + c * ax[1]])


def tree_coordinates(scene: Scene, topo: Topology, poses: np.ndarray, vels: np.ndarray):
    """Map absolute poses (nb x 3: x, y, theta) and velocities to tree coordinates q, qd."""
    n = len(topo.coords)
    q, qd = np.zeros(n), np.zeros(n)
    names = topo.body_names
    for b, e in enumerate(topo.edges):
        if e.kind == "free":
            kx, ky, kt = e.coords
            q[[kx, ky, kt]] = poses[b]
            qd[[kx, ky, kt]] = vels[b]
            continue
        k = e.coords[0]
        pth = 0.0 if e.parent == GROUND else poses[e.parent, 2]
        pw = 0.0 if e.parent == GROUND else vels[e.parent, 2]
        if e.kind in ("crank", "rev"):
            q[k] = poses[b, 2] - pth
            qd[k] = vels[b, 2] - pw
        else:
            j = scene.joints[e.joint]
            u = _guide_direction(j, pth)
            rg, vg = world_point(scene, names, poses, vels, e.parent, e.parent_point)
            rs, vs = world_point(scene, names, poses, vels, b, e.child_point)
            q[k] = float((rs - rg) @ u)
            udot = pw * np.array([-u[1], u[0]])
            qd[k] = float((vs - vg) @ u + (rs - rg) @ udot)
    return q, qd


def initial_coordinates(scene: Scene, topo: Topology):
    """Assembled tree coordinates q, qd at t = 0 (all joints closed, ideal velocities)."""
    from nld.model.ideal import assemble
    poses, vels = assemble(scene, 0.0)
    return tree_coordinates(scene, topo, poses, vels)


def constraint_jacobian_at_assembly(scene: Scene, topo: Topology) -> np.ndarray:
    """Jacobian of the loop-cut constraints w.r.t. tree coordinates, by central differences."""
    from nld.model.ideal import assemble
    poses, vels = assemble(scene, 0.0)
    q0, _ = tree_coordinates(scene, topo, poses, vels)
    m, n = 2 * len(topo.cuts), len(topo.coords)
    J = np.zeros((m, n))
    h = 1e-7
    for k in range(n):
        for sgn in (1, -1):
            q = q0.copy()
            q[k] += sgn * h
            J[:, k] += sgn * _cut_residual(scene, topo, q) / (2 * h)
    return J


def forward_poses(scene: Scene, topo: Topology, q: np.ndarray) -> np.ndarray:
    """Absolute poses (nb x 3) from tree coordinates (positions only), in Python."""
    nb = len(topo.body_names)
    poses = np.zeros((nb, 3))
    zero = np.zeros((nb, 3))
    names = topo.body_names
    for b in topo.order:
        e = topo.edges[b]
        if e.kind == "free":
            poses[b] = q[e.coords]
            continue
        k = e.coords[0]
        pth = 0.0 if e.parent == GROUND else poses[e.parent, 2]
        bx, by = scene.bodies[names[b]].points[e.child_point]
        if e.kind in ("crank", "rev"):
            rj, _ = world_point(scene, names, poses, zero, e.parent, e.parent_point)
            th = pth + q[k]
        else:
            j = scene.joints[e.joint]
            u = _guide_direction(j, pth)
            rg, _ = world_point(scene, names, poses, zero, e.parent, e.parent_point)
            rj = rg + q[k] * u
            b0, b1 = j.bodies
            off = (scene.bodies[b1].angle0 if b1 != "ground" else 0.0) - (
                scene.bodies[b0].angle0 if b0 != "ground" else 0.0)
            th = pth + off
        c, s = math.cos(th), math.sin(th)
        poses[b] = [rj[0] - (c * bx - s * by), rj[1] - (s * bx + c * by), th]
    return poses


def _cut_residual(scene: Scene, topo: Topology, q: np.ndarray) -> np.ndarray:
    poses = forward_poses(scene, topo, q)
    zero = np.zeros_like(poses)
    out = []
    for jn in topo.cuts:
        j = scene.joints[jn]
        ra, _ = world_point(scene, topo.body_names, poses, zero, topo.body_index(j.bodies[0]), j.points[0])
        rb, _ = world_point(scene, topo.body_names, poses, zero, topo.body_index(j.bodies[1]), j.points[1])
        out.extend(ra - rb)
    return np.array(out)
