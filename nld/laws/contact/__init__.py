"""The normal-contact laws, one file each (registry and recipe: nld.laws.law,
docs/contact-laws.md "Adding a contact law").

Notation shared by every law:

* ``delta``  penetration depth (m), ``delta = |e| - c`` with ``e`` the journal-centre offset and
  ``c = R_bearing - R_journal`` the radial clearance; no contact when ``delta <= 0``;
* ``ddot``   penetration rate d(delta)/dt (m/s), positive while approaching (compression),
  negative while separating (restitution);
* ``K``      generalised stiffness (N/m^n; N/m^1.5 for the Hertz exponent n = 1.5);
* ``n``      force exponent (-), 1.5 for Hertz point contact;
* ``cr``     coefficient of restitution (-), 0 < cr <= 1;
* ``v_minus`` approach velocity at contact onset (m/s), > 0. The laws do not floor it: the caller
  stores ``max(ddot_at_onset, min_approach_velocity)`` so the division is always by a positive value.

Every law returns ``max(F, 0.0)``: the joint cannot pull (no adhesion), so a damping term that would
make the force negative late in restitution is clamped to zero. Every law returns 0 for
``delta <= 0``.

The seed paper (Zhang, Liu, Xu, Hou 2013, excavating system with two clearances, eqs 6-9)
writes ``F_n = K delta^1.5 + C v_n`` with K printed in N/m^2; with the exponent 1.5 the
consistent unit is N/m^1.5, which is what is used here.
"""
