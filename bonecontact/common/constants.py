"""Physical constants and time units shared by all layers (SI units)."""

from __future__ import annotations

__all__ = ["R_GAS", "SECONDS_PER_DAY", "SECONDS_PER_YEAR"]

#: Molar gas constant (J mol⁻¹ K⁻¹).
R_GAS = 8.314462618
#: One day (s).
SECONDS_PER_DAY = 86400.0
#: Julian year (s).
SECONDS_PER_YEAR = 365.25 * SECONDS_PER_DAY
