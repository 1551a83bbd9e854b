"""Exceptions of nld. Every input error is one line naming the field, the value and what is allowed."""


class SceneError(ValueError):
    """Bad scene or parameter input.

    The message has the form ``<field path> = <value>: <what is allowed>`` on one line,
    e.g. ``joints.B.clearance = -0.001: must be >= 0 (m)``.
    """

    def __init__(self, path: str, value, allowed: str):
        self.path = path
        self.value = value
        self.allowed = allowed
        super().__init__(f"{path} = {value!r}: {allowed}")


class InputError(ValueError):
    """Bad input that is not a scene field (a file that cannot be read, a malformed option)."""


class SolveError(RuntimeError):
    """An integration that could not meet its tolerance; the message says where and why."""
