"""Small numba helpers that generated kernels import."""
import numpy as np
from numba import njit


@njit(cache=True)
def periodic_table(angle, p, ia, iv, n):
    """Periodic piecewise-linear factor of the crank angle (rad) from a table in p[ia:ia+n], p[iv:iv+n].

    The table covers [0, 2 pi); between its last and first entry it wraps around.
    """
    a = angle % (2.0 * np.pi)
    if n == 1:
        return p[iv]
    if a < p[ia]:
        a0, v0 = p[ia + n - 1] - 2.0 * np.pi, p[iv + n - 1]
        a1, v1 = p[ia], p[iv]
    elif a >= p[ia + n - 1]:
        a0, v0 = p[ia + n - 1], p[iv + n - 1]
        a1, v1 = p[ia] + 2.0 * np.pi, p[iv]
    else:
        k = 0
        while p[ia + k + 1] <= a:
            k += 1
        a0, v0, a1, v1 = p[ia + k], p[iv + k], p[ia + k + 1], p[iv + k + 1]
    if a1 == a0:
        return v0
    return v0 + (v1 - v0) * (a - a0) / (a1 - a0)


def writable_vector(a) -> np.ndarray:
    """``a`` as a writable, C-contiguous float64 array (itself when it already is one, else a copy).

    numba compiles one specialisation per argument type, and a read-only array (a pandas
    column, a broadcast) is another type than a writable one: the generated ``solve`` wrappers
    pass every array through this so that one compiled integrator serves every caller."""
    if isinstance(a, np.ndarray) and a.dtype == np.float64 and a.flags.c_contiguous and a.flags.writeable:
        return a
    return np.array(a, dtype=np.float64)
