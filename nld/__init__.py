"""nld: nonlinear dynamics and chaos of planar mechanisms with joint clearance."""
__version__ = "0.1.0"


def __getattr__(name):
    # lazy public API, so that `import nld` stays light
    if name in ("load_scene", "builtin_scenes"):
        from . import scene
        return getattr(scene, name)
    if name in ("simulate", "SimulationResult"):
        from . import simulate
        return getattr(simulate, name)
    if name == "compile_scene":
        from .kernel import compile_scene
        return compile_scene
    raise AttributeError(name)
