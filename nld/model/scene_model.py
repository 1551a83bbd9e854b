"""Data model of a scene: the planar mechanism a simulation runs on.

All quantities are SI: m, kg, s, rad, N, N m. Points are in the body frame relative to the
centre of mass (ground points in the global frame). See docs/scene-format.md.
"""
from __future__ import annotations

from dataclasses import dataclass, field

FRICTION_LAWS = ("none", "coulomb", "ambrosio")
JOINT_TYPES = ("revolute", "prismatic")
DRIVER_MODES = ("speed", "torque")
LOAD_TYPES = ("force", "torque", "spring")
MODULATIONS = ("constant", "crank_halves", "angle_threshold", "crank_table")
CONTROL_METHODS = ("pyragas", "edfc", "ogy")


@dataclass
class Body:
    name: str
    mass: float                      # kg
    inertia: float                   # kg m^2 about the centre of mass
    points: dict[str, tuple[float, float]] = field(default_factory=dict)   # m, body frame
    angle0: float = 0.0              # rad, assembly hint


@dataclass
class Contact:
    law: str = "lankarani_nikravesh"
    stiffness: float | None = None   # N/m^exponent; None -> from young/poisson and the radii
    young: tuple[float, float] = (207e9, 207e9)     # Pa, (journal, bearing)
    poisson: tuple[float, float] = (0.3, 0.3)
    exponent: float = 1.5
    restitution: float = 0.9
    damping: float = 0.0             # N s/m (hertz_damped only)
    min_approach_velocity: float = 1e-4   # m/s


@dataclass
class Friction:
    law: str = "none"
    mu: float = 0.0
    v0: float = 1e-4                 # m/s
    v1: float = 1e-2                 # m/s
    tangential_damping: float = 0.0  # N s/m
    mu_s: float | None = None        # static coefficient (coulomb stick), None: = mu


@dataclass
class Joint:
    name: str
    type: str                        # "revolute" | "prismatic"
    bodies: tuple[str, str]          # (journal/first, bearing/second); "ground" allowed
    points: tuple[str, str]
    clearance: float = 0.0           # m (revolute only)
    journal_radius: float = 0.0      # m
    axis: tuple[float, float] = (1.0, 0.0)   # prismatic: guide direction in first body's frame
    contact: Contact = field(default_factory=Contact)
    friction: Friction = field(default_factory=Friction)

    @property
    def has_clearance(self) -> bool:
        return self.type == "revolute" and self.clearance > 0.0


@dataclass
class Driver:
    joint: str
    mode: str = "speed"
    speed: float = 0.0               # rad/s
    angle0: float = 0.0              # rad
    inertia: float = 0.0             # kg m^2
    torque: float = 0.0              # N m
    torque_slope: float = 0.0        # N m s/rad


@dataclass
class Load:
    type: str                        # "force" | "torque" | "spring"
    body: str = ""
    point: str = ""
    value: float | tuple[float, float] = 0.0
    modulation: str = "constant"
    threshold: float = 0.0           # rad (angle_threshold)
    table_angles: tuple[float, ...] = ()
    table_values: tuple[float, ...] = ()
    bodies: tuple[str, str] = ("", "")   # spring
    points: tuple[str, str] = ("", "")
    stiffness: float = 0.0           # N/m
    free_length: float = 0.0         # m
    damping: float = 0.0             # N s/m


@dataclass
class Controller:
    """A feedback torque on a body (issue 26, docs/control.md): the scene loader turns it into a
    torque load of value ``offset`` (N m) on ``body``, appended after the file's loads at index
    ``load``; ``nld control`` (nld.analysis.control, input "param") drives that load's value
    ``loads.<load>.value``. With gain 0, or without ``nld control``, the torque is the constant
    offset (default 0: the uncontrolled mechanism)."""
    body: str
    signal: str = ""                 # measured state, e.g. "rod.phi_dot" (checked by nld control)
    method: str = "pyragas"          # pyragas | edfc | ogy
    gain: float = 0.0                # N m per unit of the signal (delayed feedback)
    delay: float | None = None       # s, tau; None: the target period (crank revolutions x period)
    memory: float = 0.0              # R in [0, 1) (edfc)
    offset: float = 0.0              # N m, the torque's constant part (OGY's parameter)
    u_max: float | None = None       # N m, clip of |u - offset|; None: no clip
    load: int = -1                   # index of the controller's torque load in Scene.loads


@dataclass
class Scene:
    name: str
    description: str = ""
    gravity: tuple[float, float] = (0.0, 0.0)       # m/s^2
    ground_points: dict[str, tuple[float, float]] = field(default_factory=dict)
    bodies: dict[str, Body] = field(default_factory=dict)
    joints: dict[str, Joint] = field(default_factory=dict)
    driver: Driver | None = None
    loads: list[Load] = field(default_factory=list)
    source: str = ""                 # file the scene came from, if any
    method: str = ""                 # recommended integrator (docs/performance.md); "" = dopri5
    rtol: float | None = None        # recommended relative tolerance; None = simulate's default
    controller: Controller | None = None   # [controller]: its torque is loads[controller.load]

    @property
    def clearance_joints(self) -> list[Joint]:
        return [j for j in self.joints.values() if j.has_clearance]
