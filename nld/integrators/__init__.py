"""Numerical integrators (numba)."""

from .dopri5 import (
    MAX_STEPS,
    NON_FINITE,
    STEP_UNDERFLOW,
    STOPPED,
    SUCCESS,
    dopri5,
    dopri5_fixed,
    no_events,
    no_on_event,
    status_message,
)

__all__ = [
    "dopri5",
    "dopri5_fixed",
    "status_message",
    "no_events",
    "no_on_event",
    "SUCCESS",
    "STOPPED",
    "MAX_STEPS",
    "STEP_UNDERFLOW",
    "NON_FINITE",
]
