"""Scale constants: feedopt computes in SI (m, s, N, rad) and talks to users in mm and deg.

``MM`` is one millimetre expressed in metres: ``x_mm * MM`` is metres and ``x_m / MM`` is
millimetres. ``MM_PER_M`` is its inverse, for code that works in millimetres internally (the
SOCP and toppra are better conditioned in mm): ``x_m * MM_PER_M`` is millimetres. A curvature
in 1/m becomes 1/mm with ``k * MM`` (metres per millimetre), not ``* MM_PER_M``.

``MS`` is one millisecond expressed in seconds: ``t_ms * MS`` is seconds (the RSI cycle is
given in ms). No other scale constant names a unit.
"""

MM = 1e-3
MM_PER_M = 1e3
MS = 1e-3
