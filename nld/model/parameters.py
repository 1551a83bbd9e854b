"""Parameter vector of a compiled scene.

Every number of a scene (masses, inertias, point coordinates, clearances, contact and friction
constants, driver and load values) travels to the kernel in one float64 array ``p``; the kernel
source holds only indices into it. Changing a number therefore never recompiles; only the structure
(which laws, which joints have clearance, whether friction or gravity is present) selects the kernel.
"""
from __future__ import annotations

import math

import numpy as np

from nld.laws.elastic import journal_bearing_stiffness
from nld.model.scene_model import Scene


class ParamLayout:
    """Names -> indices of the parameter vector. Names follow the scene's structure."""

    def __init__(self):
        self.names: list[str] = []
        self.index: dict[str, int] = {}

    def add(self, name: str, n: int = 1) -> int:
        if name in self.index:
            return self.index[name]
        i = len(self.names)
        if n == 1:
            self.names.append(name)
        else:
            self.names.extend(f"{name}[{k}]" for k in range(n))
        self.index[name] = i
        return i

    def __len__(self):
        return len(self.names)


def contact_stiffness(joint) -> float:
    """Stiffness K (N/m^n) of a clearance joint: given, or from E, nu and the radii (refs §4)."""
    c = joint.contact
    if c.stiffness is not None:
        return float(c.stiffness)
    rj = joint.journal_radius
    return journal_bearing_stiffness(rj, rj + joint.clearance, c.young[0], c.poisson[0], c.young[1], c.poisson[1])


def build_layout(scene: Scene) -> ParamLayout:
    L = ParamLayout()
    L.add("gravity", 2)
    for name in scene.ground_points:
        L.add(f"ground.points.{name}", 2)
    for b in scene.bodies.values():
        L.add(f"bodies.{b.name}.mass")
        L.add(f"bodies.{b.name}.inertia")
        for pn in b.points:
            L.add(f"bodies.{b.name}.points.{pn}", 2)
    for j in scene.joints.values():
        if j.type == "prismatic":
            L.add(f"joints.{j.name}.axis", 2)
            L.add(f"joints.{j.name}.angle_offset")
            L.add(f"joints.{j.name}.angle_offset_cos")
            L.add(f"joints.{j.name}.angle_offset_sin")
        if j.has_clearance:
            for k in ("clearance", "journal_radius", "contact.stiffness", "contact.exponent",
                      "contact.restitution", "contact.damping", "contact.min_approach_velocity",
                      "friction.mu", "friction.v0", "friction.v1", "friction.tangential_damping",
                      "friction.mu_s"):
                L.add(f"joints.{j.name}.{k}")
    if scene.driver is not None:
        for k in ("speed", "angle0", "inertia", "torque", "torque_slope"):
            L.add(f"driver.{k}")
    for i, ld in enumerate(scene.loads):
        if ld.type == "force":
            L.add(f"loads.{i}.value", 2)
        elif ld.type == "torque":
            L.add(f"loads.{i}.value")
        elif ld.type == "spring":
            for k in ("stiffness", "free_length", "damping"):
                L.add(f"loads.{i}.{k}")
        if ld.modulation == "angle_threshold":
            L.add(f"loads.{i}.threshold")
        if ld.modulation == "crank_table":
            L.add(f"loads.{i}.table_angles", len(ld.table_angles))
            L.add(f"loads.{i}.table_values", len(ld.table_values))
    return L


def pack(scene: Scene, layout: ParamLayout) -> np.ndarray:
    """Fill the parameter vector of ``scene`` (SI units) for a kernel built with ``layout``."""
    p = np.zeros(len(layout))
    ix = layout.index

    def put(name, value):
        i = ix[name]
        v = np.atleast_1d(np.asarray(value, dtype=float))
        p[i:i + len(v)] = v

    put("gravity", scene.gravity)
    for name, xy in scene.ground_points.items():
        put(f"ground.points.{name}", xy)
    for b in scene.bodies.values():
        put(f"bodies.{b.name}.mass", b.mass)
        put(f"bodies.{b.name}.inertia", b.inertia)
        for pn, xy in b.points.items():
            put(f"bodies.{b.name}.points.{pn}", xy)
    for j in scene.joints.values():
        if j.type == "prismatic":
            a = np.asarray(j.axis, dtype=float)
            put(f"joints.{j.name}.axis", a / math.hypot(*a))
            off = 0.0
            b0, b1 = j.bodies
            off = (scene.bodies[b1].angle0 if b1 != "ground" else 0.0) - (
                scene.bodies[b0].angle0 if b0 != "ground" else 0.0)
            put(f"joints.{j.name}.angle_offset", off)
            put(f"joints.{j.name}.angle_offset_cos", math.cos(off))
            put(f"joints.{j.name}.angle_offset_sin", math.sin(off))
        if j.has_clearance:
            pre = f"joints.{j.name}."
            put(pre + "clearance", j.clearance)
            put(pre + "journal_radius", j.journal_radius)
            put(pre + "contact.stiffness", contact_stiffness(j))
            put(pre + "contact.exponent", j.contact.exponent)
            put(pre + "contact.restitution", j.contact.restitution)
            put(pre + "contact.damping", j.contact.damping)
            put(pre + "contact.min_approach_velocity", j.contact.min_approach_velocity)
            put(pre + "friction.mu", j.friction.mu)
            put(pre + "friction.v0", j.friction.v0)
            put(pre + "friction.v1", j.friction.v1)
            put(pre + "friction.tangential_damping", j.friction.tangential_damping)
            put(pre + "friction.mu_s", j.friction.mu if j.friction.mu_s is None else j.friction.mu_s)
    d = scene.driver
    if d is not None:
        for k in ("speed", "angle0", "inertia", "torque", "torque_slope"):
            put(f"driver.{k}", getattr(d, k))
    for i, ld in enumerate(scene.loads):
        if ld.type in ("force", "torque"):
            put(f"loads.{i}.value", ld.value)
        elif ld.type == "spring":
            for k in ("stiffness", "free_length", "damping"):
                put(f"loads.{i}.{k}", getattr(ld, k))
        if ld.modulation == "angle_threshold":
            put(f"loads.{i}.threshold", ld.threshold)
        if ld.modulation == "crank_table":
            put(f"loads.{i}.table_angles", ld.table_angles)
            put(f"loads.{i}.table_values", ld.table_values)
    return p
