"""nld: nonlinear dynamics and chaos of planar mechanisms with joint clearance.

    import nld
    res = nld.simulate("slider_crank", revs=2)      # nld.simulate is the function
    scene = nld.load_scene("four_bar")

The function ``simulate`` and the module ``nld.simulate`` share a name: the function is bound here
after the module is imported, and a later ``import nld.simulate`` does not rebind it.
"""
__version__ = "0.1.0"

from .simulate import SimulationResult, simulate  # noqa: E402,F401  (binds the function)


def __getattr__(name):
    # the rest of the public API is imported on first use
    import importlib
    if name in ("load_scene", "builtin_scenes"):
        return getattr(importlib.import_module(".scene", __name__), name)
    if name == "compile_scene":
        return importlib.import_module(".kernel", __name__).compile_scene
    raise AttributeError(f"module 'nld' has no attribute {name!r}")
