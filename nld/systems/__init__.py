"""Dynamical systems every analysis takes: a continuous system (ODE with optional events and
discrete state), a discrete map, the example systems (Lorenz, Duffing, linear, logistic, Henon), a
scene wrapped as a system (SceneSystem) and the tangent view (tangent)."""
from nld.systems.core import (  # noqa: F401
    ContinuousSystem, DiscreteMap, SceneSystem, advance, duffing, henon, iterate, linear, logistic,
    lorenz, period_shift, trajectory, wrap_angles,
    builtin_map, builtin_map_jac, duffing_rhs, henon_f, henon_jac, linear_rhs, logistic_f, logistic_jac,
    lorenz_rhs)
