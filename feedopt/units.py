"""Scale constants: feedopt computes in SI (m, s, N, rad) and talks to users in mm and deg.

``MM`` is one millimetre expressed in metres: ``x_mm * MM`` is metres and ``x_m / MM`` is
millimetres. Every module converts with this one constant.
"""

MM = 1e-3
