"""nld: nonlinear dynamics and chaos of planar mechanisms with joint clearance.

    import nld
    res = nld.simulate("slider_crank", revs=2)      # the function nld.run.simulate.simulate
    scene = nld.load_scene("four_bar")

The package follows the pipeline scene -> kernel -> run -> system -> analysis -> output, with the
command line on top (docs/architecture.md): ``nld.model`` (scenes), ``nld.laws`` (contact and
friction laws), ``nld.kernel`` (code generation and compilation), ``nld.integrators``, ``nld.run``
(simulate), ``nld.systems`` (ODEs, maps, scenes as systems, tangent view), ``nld.analysis``,
``nld.output`` (tables, reports) and ``nld.cli``.
"""
from nld.version import __version__  # noqa: E402,F401



def __getattr__(name):
    # the public API is imported on first use: ``import nld`` (and the command line's start, which
    # installs its Ctrl-C handler right after it) stays quick; nld.simulate is the function
    import importlib
    if name in ("simulate", "SimulationResult"):
        return getattr(importlib.import_module("nld.run.simulate"), name)
    if name in ("load_scene", "builtin_scenes"):
        return getattr(importlib.import_module("nld.model.scene"), name)
    if name == "compile_scene":
        return importlib.import_module("nld.kernel.compile").compile_scene
    raise AttributeError(f"module 'nld' has no attribute {name!r}")
