"""Pure-UFL forms of bonecontact (no DOLFINx imports).

The modules read as the mathematics of docs/theory/mechanics.md:

* :mod:`.kinematics` — small strain, Voigt vectors, stress from a Voigt stiffness;
* :mod:`.elastic` — elastic form a⁽⁰⁾ and the volumetric (nodal-pressure) pieces;
* :mod:`.viscous` — Kelvin–Voigt viscous form a⁽¹⁾;
* :mod:`.mass` — mass form (ρu, v);
* :mod:`.loads` — traction, pressure and body-force load forms;
* :mod:`.kelvin_voigt` — the time-discrete bilinear form A and right-hand side ℓ of
  the semi-implicit scheme (docs/theory/mechanics.md#time-discretisation), and a concrete instance
  that ``ffcx`` can
  compile ahead of time (``ffcx forms/kelvin_voigt.py``).

The package installs this directory as ``bonecontact.forms``.
"""
