"""Scene -> compiled numba kernel: code generation (codegen), source-to-source forward-mode
differentiation for the tangent dynamics (autodiff), the helpers generated code calls (support) and
compilation with its disk cache (compile)."""
from nld.kernel.compile import Kernel, cache_dir, compile_scene  # noqa: F401
