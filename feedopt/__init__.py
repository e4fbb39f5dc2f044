"""feedopt: deflection-limited, C2 feed-rate planning for milling with industrial robots.

Stages (see ``shared/design.md``): geometry -> process -> robot -> schedule -> verify ->
export -> report, wired together only by :mod:`feedopt.runner`.
Internal units are SI (m, s, N, rad); files people read use mm, mm/s, deg, rpm.
"""

__version__ = "0.1.0"
