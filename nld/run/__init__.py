"""Running a scene: :func:`nld.run.simulate.simulate` (tables of states and joint forces over time)
and the named hard regression cases (hard_cases).

``nld.run.simulate`` is the function (as ``nld.simulate``); the module is
``importlib.import_module("nld.run.simulate")`` or reached by ``from nld.run.simulate import ...``."""
from nld.run.simulate import SimulationResult, simulate  # noqa: F401  (binds the function)
