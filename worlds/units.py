"""Unit factors of world-file keys: a key spelled in a unit (``_deg_h``, ``_mg``, ...) is
multiplied by its factor on load to give the SI value its dataclass field names."""

from __future__ import annotations

import math

DEG = math.pi / 180.0  # deg -> rad
ARCSEC = DEG / 3600.0  # arcsec -> rad
DEG_H = DEG / 3600.0  # deg/h -> rad/s
DEG_SQRT_H = DEG / 60.0  # deg/sqrt(h) -> rad/sqrt(s)
DEG_H_SQRT_H = DEG / 3600.0 / 60.0  # (deg/h)/sqrt(h) -> rad/s/sqrt(s)
MG = 9.80665e-3  # milli-g -> m/s^2
MG_SQRT_H = MG / 60.0  # mg/sqrt(h) -> m/s^2/sqrt(s)
MPS_SQRT_H = 1.0 / 60.0  # m/s/sqrt(h) -> m/s/sqrt(s)
