"""The contact-law registry: what a law is, and where the code generator finds it.

A contact law is one file in ``nld/laws/contact/`` (docs/contact-laws.md, "Adding a contact law")
holding

* its force, a numba function ``force(delta, ddot, K, n, *extra) -> F_n`` (N) of the penetration
  ``delta`` (m), its rate ``ddot`` (m/s, > 0 approaching), the stiffness ``K`` (N/m^n) and the
  exponent ``n`` (-), followed by the ``extra`` arguments the law names;
* ``LAW = ContactLaw(...)``, which says which extra arguments it takes and how it switches.

The scene's ``[joints.X.contact] law = "<name>"`` picks it; the file is found by its name when
``nld.laws.law`` is first used (every module of the package with a ``LAW``), so nothing else is
edited. ``register`` adds a law defined outside the package (its module must be importable in
every process that compiles a kernel with it, e.g. sweep workers).

Events and saltation: a law whose force is continuous at contact onset (every law with a
``delta^n`` factor on its damping) needs no event of its own beyond the penetration event every
clearance joint has. A law whose force jumps at onset (``jump_at_onset``, e.g. ``hertz_damped``,
F = K delta^n + C ddot jumps by C ddot0) runs contact as a mode switched at the located onset and
at the located zero of its ``unclamped`` force (the clamp at F = 0 during restitution), so every
step integrates one smooth branch. The saltation matrix of either event needs nothing from the
law: the tangent integrator builds it from the event function's gradient and the vector fields
before and after (Müller 1995; docs/lyapunov.md), and the generated tangent code differentiates
the law's force by source transformation (nld.kernel.autodiff), so a law must be written in the
subset that autodiff knows (arithmetic, ``max``/``min``, ``if``, numpy's elementary functions).
"""
from __future__ import annotations

import importlib
import pkgutil
import threading
from dataclasses import dataclass
from typing import Callable

# extra arguments a law may take, after (delta, ddot, K, n): scene fields of [joints.X.contact]
# and the approach velocity stored at the located onset
EXTRA_ARGUMENTS = {
    "restitution": "coefficient of restitution cr (-), joints.X.contact.restitution",
    "damping": "damping coefficient C (N s/m), joints.X.contact.damping",
    "v_minus": "approach velocity at the located onset (m/s), floored by "
               "joints.X.contact.min_approach_velocity",
}


@dataclass(frozen=True)
class ContactLaw:
    """One normal-contact law of a revolute clearance joint.

    name: the scene's ``contact.law`` value. force: numba function ``force(delta, ddot, K, n,
    *extra)`` (N), >= 0, 0 for delta <= 0. extra: the names of the arguments after n, from
    ``EXTRA_ARGUMENTS``. jump_at_onset: the force jumps at contact onset, so contact is a mode
    switched at located events (then ``unclamped`` is required: the force before its clamp at
    zero, whose zero is the clamp event; and ``mode_force``: the force the kernel runs while the
    contact mode is on, continuous at delta <= 0, since the located onset has delta = 0 only to
    the root tolerance). conservative: the law stores and returns energy without
    loss (the kernels' energy-balance checks use it). reference: the source, for docs and reports.
    """
    name: str
    force: Callable
    extra: tuple[str, ...] = ()
    jump_at_onset: bool = False
    unclamped: Callable | None = None
    mode_force: Callable | None = None
    conservative: bool = False
    reference: str = ""

    def __post_init__(self):
        bad = [e for e in self.extra if e not in EXTRA_ARGUMENTS]
        if bad:
            raise ValueError(f"contact law {self.name!r}: extra argument {bad[0]!r} is not one of "
                             f"{', '.join(EXTRA_ARGUMENTS)}")
        if self.jump_at_onset and self.onset_velocity:
            raise ValueError(f"contact law {self.name!r}: a law with jump_at_onset cannot take v_minus "
                             f"(its z slot holds the contact mode)")
        if self.jump_at_onset and (self.unclamped is None or self.mode_force is None):
            raise ValueError(f"contact law {self.name!r}: jump_at_onset needs the unclamped force "
                             f"and the contact-mode force")

    @property
    def onset_velocity(self) -> bool:
        """The law divides by the approach velocity stored at the located onset (v_minus)."""
        return "v_minus" in self.extra

    def functions(self) -> list[Callable]:
        """The numba functions generated kernels call: the force, and the unclamped force."""
        return [self.force] + [f for f in (self.unclamped, self.mode_force) if f is not None]


_LAWS: dict[str, ContactLaw] = {}
_FOUND = False
# discovery runs once per process, under a lock: a study's second thread (nld.study.Background)
# reading the registry while the first still fills it saw no law at all ("must be one of: ")
_DISCOVERY = threading.Lock()


def _discover() -> None:
    global _FOUND
    if _FOUND:
        return
    with _DISCOVERY:
        if _FOUND:
            return
        from nld.laws import contact
        for info in sorted(pkgutil.iter_modules(contact.__path__), key=lambda m: m.name):
            mod = importlib.import_module(f"{contact.__name__}.{info.name}")
            law = getattr(mod, "LAW", None)
            if isinstance(law, ContactLaw):
                register(law)
        _FOUND = True


def register(law: ContactLaw) -> ContactLaw:
    """Add a law to the registry (its name must be new); returns it."""
    if not isinstance(law, ContactLaw):
        raise TypeError(f"register() takes a ContactLaw, not {type(law).__name__}")
    old = _LAWS.get(law.name)
    if old is not None and old is not law:
        raise ValueError(f"contact law {law.name!r} is already registered (from {old.force.__module__})")
    _LAWS[law.name] = law
    return law


def contact_law(name: str) -> ContactLaw:
    """The registered law of that name (KeyError naming the known ones otherwise)."""
    _discover()
    try:
        return _LAWS[name]
    except KeyError:
        raise KeyError(f"no contact law {name!r}; known: {', '.join(contact_laws())}") from None


def contact_laws() -> tuple[str, ...]:
    """The names of the registered contact laws, built-in ones first in file order."""
    _discover()
    return tuple(_LAWS)
