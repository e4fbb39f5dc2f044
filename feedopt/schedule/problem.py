"""What every timing law is given: the sampled path, its feed bound and the robot's limits.

The runner builds one :class:`ScheduleProblem` per scenario (from the geometry, process and
robot stages and :mod:`feedopt.schedule.bounds`) and hands the same object to every law, so
laws never reach into other stages.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from feedopt.schedule.joints import JointScreen, joint_screen


@dataclass(frozen=True)
class StopSamples:
    """Samples where the path stops: feed, acceleration and jerk are zero there, and the
    tool is held ``hold_s`` (a G4 dwell; 0 for an exact stop, a reversal, M0).

    index : (k,) increasing sample indices (0 and n - 1 allowed: a hold at the start or end)
    hold_s : (k,) hold duration at each [s], >= 0
    kind : (k,) why (:class:`feedopt.gcode.moves.StopKind` values)
    label : (k,) where, for messages (``"line 12 (N120): G4 P1"``)
    """

    index: np.ndarray
    hold_s: np.ndarray
    kind: tuple[str, ...]
    label: tuple[str, ...]

    def __len__(self) -> int:
        return int(self.index.size)


@dataclass(frozen=True)
class ScheduleProblem:
    """A time-parameterisation problem along a fixed path.

    Attributes
    ----------
    s : (n,) array
        Arc length of the path samples [m], strictly increasing, ``s[0] == 0``.
    v_max : (n,) array
        Upper bound on the path velocity sdot at each sample [m/s] (deflection limit, user
        max feed, spindle power/torque, joint velocity: the tightest of them). Positive.
    q : (n, dof) array
        Joint path at the samples [rad] (continuous, from IK).
    dq_ds, d2q_ds2 : (n, dof) arrays
        First and second derivatives of the joint path w.r.t. arc length [rad/m, rad/m^2].
    joint_velocity_max, joint_acceleration_max : (dof,) arrays
        Symmetric joint limits [rad/s, rad/s^2].
    accel_max : float
        Tangential acceleration limit |sddot| [m/s^2] (``inf`` if none).
    jerk_max : float
        Tangential jerk limit |sdddot| [m/s^3] (``inf`` if none). Laws that produce C2
        trajectories (convex, jerk) must respect it; ``thesis`` reports what it reaches.
    nominal_feed : float
        The user's nominal feed [m/s] (the ``constant`` law runs at it).
    v_start, v_end : float
        Boundary feeds [m/s]; 0 means start and end at rest.
    segment_start : (k,) array
        Arc length at which each geometric segment starts [m] (``segment_start[0] == 0``).
    segment_kind : tuple of str, length k
        ``"line"`` or the blend kind (``"circle"``, ``"bezier4"``, ``"bezier5"``,
        ``"varying_radius"``) of each segment.
    key_point_spacing : float
        Spacing l of the chapter-4 key points along lines [m] (thesis 4.2); 0 = not used.
    programmed_feed : (n,) array or None
        A G-code program's own feed at each sample [m/s] (its move's F; on rapids the rapid
        limit, ``inf`` for none), capped by the joint velocity limits; None for other paths
        (one nominal feed). The ``constant`` law runs one feed and declines such paths; the
        ``programmed`` baseline runs this.
    stops : StopSamples or None
        Samples where the trajectory must stop (and hold); None: it stops only at the ends.
        :func:`feedopt.schedule.laws.plan_law` plans such a problem piece by piece between
        the stops (:mod:`feedopt.schedule.stops`).
    orientation : the tool vector u(s) of a five-axis path (anything with ``evaluate(s)``
        giving ``d1``, ``d2``: :class:`feedopt.geometry.orientation.ToolOrientation`); None
        on three-axis paths. The replay checks its rate and acceleration against
    orientation_rate_max, orientation_acceleration_max : float
        [rad/s, rad/s^2] (``inf``: none); the feed bound keeps them
        (:mod:`feedopt.schedule.orientation_limits`).
    """

    s: np.ndarray
    v_max: np.ndarray
    q: np.ndarray
    dq_ds: np.ndarray
    d2q_ds2: np.ndarray
    joint_velocity_max: np.ndarray
    joint_acceleration_max: np.ndarray
    accel_max: float
    jerk_max: float
    nominal_feed: float
    v_start: float = 0.0
    v_end: float = 0.0
    segment_start: np.ndarray | None = None
    segment_kind: tuple[str, ...] = ()
    key_point_spacing: float = 0.0
    programmed_feed: np.ndarray | None = None
    stops: StopSamples | None = None
    orientation: object | None = None
    orientation_rate_max: float = np.inf
    orientation_acceleration_max: float = np.inf

    @cached_property
    def joint_screen(self) -> JointScreen:
        """Bounds of the joint rates on every sample interval per unit of feed and path
        acceleration (:class:`feedopt.schedule.joints.JointScreen`), computed once: where the
        dense replay of the joints must look."""
        return joint_screen(self)

    @property
    def length(self) -> float:
        """Path length [m]."""
        return float(self.s[-1])

    @property
    def n(self) -> int:
        """Number of path samples."""
        return int(self.s.size)

    def lower_bound_time(self) -> float:
        """T* = integral of ds / v_max(s): no law obeying v_max can be faster.

        The bound is only known at the samples (that is also where laws are verified), so
        the integral is the trapezoidal rule on 1/v_max over the samples.
        """
        return float(np.trapezoid(1.0 / self.v_max, self.s))

    def segments(self) -> list[tuple[float, float, str]]:
        """Segments as ``(s_start, s_end, kind)``; one ``line`` if none were given."""
        if self.segment_start is None or len(self.segment_kind) == 0:
            return [(0.0, self.length, "line")]
        ends = np.append(self.segment_start[1:], self.length)
        return [
            (float(a), float(b), k)
            for a, b, k in zip(self.segment_start, ends, self.segment_kind, strict=True)
        ]
