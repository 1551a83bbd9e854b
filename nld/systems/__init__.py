"""Dynamical systems every analysis takes, all implementing one interface (base: System, the one
integrator call ``integrate`` and its typed ``Solution``): a continuous system (ODE with optional events and
discrete state), a discrete map, the example systems (Lorenz, Duffing, linear, logistic, Henon,
the impact oscillator, Rössler), a scene wrapped as a system (SceneSystem), the tangent view (tangent) and
the derived maps of a flow (derived: stroboscopic and Poincaré maps with their Jacobians)."""
from nld.systems.base import Solution, System, integrate  # noqa: F401
from nld.systems.core import (  # noqa: F401
    ContinuousSystem, DiscreteMap, SceneSystem, advance, duffing, henon, iterate, linear, logistic,
    lorenz, period_shift, trajectory, wrap_angles,
    builtin_map, builtin_map_jac, duffing_rhs, henon_f, henon_jac, linear_rhs, logistic_f, logistic_jac,
    lorenz_rhs)
from nld.systems.impact import impact_oscillator  # noqa: F401
from nld.systems.rossler import rossler, rossler_rhs  # noqa: F401
from nld.systems.derived import PoincareMap, StroboscopicMap, as_map  # noqa: F401
