"""Install-time step of nld: build the integrator cores ahead of time (nld/integrators/aot.py).

Everything else about the package is in pyproject.toml. After setuptools has laid out the
package (a wheel's build directory, or the source tree for ``pip install -e .``), the five
integrator cores are compiled with numba.pycc into extension modules beside their sources, so
that the first run on a new machine does not wait on numba's compiler for them
(docs/performance.md, "Built at install"). Where that build cannot run (no C compiler, another
platform), the install goes on and nld compiles the cores on first use, as before; set
``NLD_AOT_BUILD=0`` to skip it.
"""
from __future__ import annotations

import importlib
import os
import sys
import time
import types
from pathlib import Path

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent


def _aot_build():
    """nld.integrators.aot_build of this source tree, imported without running nld/__init__.py
    (the build environment has numpy and numba only; nld.integrators needs no more)."""
    if "nld" not in sys.modules:
        pkg = types.ModuleType("nld")
        pkg.__path__ = [str(ROOT / "nld")]
        sys.modules["nld"] = pkg
    return importlib.import_module("nld.integrators.aot_build")


class build_py_with_cores(build_py):
    """build_py, then the ahead-of-time build of the integrator cores into the package."""

    def run(self):
        super().run()
        if os.environ.get("NLD_AOT_BUILD", "1") == "0":
            return
        if getattr(self, "editable_mode", False):
            out = ROOT / "nld" / "integrators"
        else:
            out = Path(self.build_lib) / "nld" / "integrators"
        t = time.perf_counter()
        try:
            paths = _aot_build().build(out)
        except Exception as e:          # never fail an install over it: the JIT stands in
            print(f"nld: the ahead-of-time build of the integrators failed ({e}); nld will "
                  f"compile them on first use instead", file=sys.stderr)
            return
        print(f"nld: built {len(paths)} integrator cores ahead of time in "
              f"{time.perf_counter() - t:.0f} s", file=sys.stderr)


class BinaryDistribution(Distribution):
    """The wheel holds compiled modules: tag it for this platform."""

    def has_ext_modules(self):
        return True


setup(cmdclass={"build_py": build_py_with_cores}, distclass=BinaryDistribution)
