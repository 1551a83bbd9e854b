"""Arrays without reference counting inside an integrator's step loop.

Every numba array carries a pointer to its owner (a "meminfo" with a reference count). Each call
of a compiled function that takes arrays -- the scene's ``rhs`` through its first-class function
pointer six times per DOPRI5 step, the out-of-line helpers -- increments and decrements the count
of every array argument that numba's reference-count pruning cannot prove redundant, and those
are *atomic* operations (``lock add`` on x86). Measured on slider_crank (20 crank revolutions,
DOPRI5, rtol 1e-8): with numba's non-atomic counts (``nrtdynmod._disable_atomicity``) a run took
37 ms against 50 ms, so about a quarter of a warm step was reference counting
(docs/performance.md, "Reference counting").

``borrowed(a)`` returns a view of ``a`` with no owner (meminfo NULL, as ``numba.carray`` builds
for foreign memory): numba's ``NRT_incref``/``NRT_decref`` return at once on it. The integrators
take borrowed views of their arguments and work arrays once, before the step loop; the arithmetic
is unchanged, so trajectories are bit-identical. The rule that keeps this safe: the owner must
outlive every use of the view. Arguments are owned by the caller for the whole call; arrays the
integrator allocates itself are kept by ``keep_alive(owners)`` after the loop (numba releases a
variable at its last use, so without it a work array could be freed while its view is in use).
A borrowed view is never returned to Python or stored: results are the owned arrays.
"""
from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic


def _view(context, builder, aryty, value):
    view = context.make_array(aryty)(context, builder, value=value)
    view.meminfo = cgutils.get_null_value(view.meminfo.type)
    view.parent = cgutils.get_null_value(view.parent.type)
    return view._getvalue()


@intrinsic
def borrowed(typingctx, arrays):
    """A view of the array ``arrays`` (same data, shape, strides) without an owner: no reference
    counting on it; for a tuple of arrays, the tuple of their views. Valid only while the owners
    are alive (module docstring)."""
    if isinstance(arrays, types.Array):
        def codegen(context, builder, sig, args):
            return _view(context, builder, sig.args[0], args[0])

        return arrays(arrays), codegen
    if isinstance(arrays, types.BaseTuple) and all(isinstance(a, types.Array) for a in arrays):
        def codegen_tuple(context, builder, sig, args):
            items = [_view(context, builder, aryty, builder.extract_value(args[0], i))
                     for i, aryty in enumerate(sig.args[0])]
            return context.make_tuple(builder, sig.return_type, items)

        return arrays(arrays), codegen_tuple
    return None


@intrinsic
def keep_alive(typingctx, owners):
    """Does nothing; a use of ``owners`` (an array or a tuple of them) at the point of the call,
    so that numba keeps them alive (does not release them) until there."""
    def codegen(context, builder, sig, args):
        return context.get_dummy_value()

    return types.none(owners), codegen
