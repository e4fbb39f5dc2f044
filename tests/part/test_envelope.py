"""The wall and floor envelope of the deflected cutter vs independent computations.

Straight paths with analytic deflections: constant D (the surface location error), D varying
over the revolution against a brute-force time stepping of the real two-flute cutter, the
level / cutting filters, and the table's periodic linear interpolation.
"""

from __future__ import annotations

import numpy as np
import pytest

from feedopt.part.envelope import DeflectionTable, SweptTool, floor_envelope, wall_envelope

R = 5e-3  # tool radius [m]
PITCH = np.pi  # two teeth
LAG = 2.0 * np.tan(np.radians(30.0)) / (2.0 * R)  # 30 deg helix [rad/m]
UM = 1e-6


def _straight(spacing: float, length: float, theta: float = 0.0, lag: float = LAG,
              origin=(0.0, 0.0, 0.0)) -> SweptTool:
    """Samples every ``spacing`` along the in-plane direction ``theta``, z constant."""
    s = np.arange(0.0, length + spacing / 2, spacing)
    x = np.array([np.cos(theta), np.sin(theta), 0.0])
    y = np.array([-np.sin(theta), np.cos(theta), 0.0])
    frame = np.column_stack([x, y, [0.0, 0.0, 1.0]])
    return SweptTool(centres=np.asarray(origin) + s[:, None] * x,
                     frames=np.tile(frame, (s.size, 1, 1)), s=s,
                     cutting=np.ones(s.size, bool), radius=R, pitch=PITCH, lag_rate=lag)


def _constant_table(d_per_sample: np.ndarray, m: int = 16) -> DeflectionTable:
    return DeflectionTable(0, np.repeat(d_per_sample[:, None, :], m, axis=1), PITCH)


def _inner(tool: SweptTool, step: int = 10) -> np.ndarray:
    """Dexel samples more than R (plus a margin) from both path ends."""
    s = tool.s
    return np.flatnonzero((s > s[0] + 1.2 * R) & (s < s[-1] - 1.2 * R))[::step]


# -- 1. constant deflection: the surface location error ------------------------------------

@pytest.mark.parametrize(("theta", "lag"), [(0.0, 0.0), (0.7, LAG), (-2.3, 3 * LAG)])
def test_constant_deflection_gives_surface_location_error(theta, lag):
    tool = _straight(0.1e-3, 40e-3, theta, lag, origin=(0.01, -0.02, 0.003))
    d = np.array([0.02, -0.03, 0.01]) * 1e-3
    table = _constant_table(np.tile(d, (tool.s.size, 1)))
    dexels = _inner(tool)
    heights = np.tile([0.0, 2e-3, 5e-3, 9e-3], (dexels.size, 1))
    y = np.array([-np.sin(theta), np.cos(theta), 0.0])
    left = wall_envelope(tool, table, dexels, 1, heights, 1e-3)
    right = wall_envelope(tool, table, dexels, -1, heights, 1e-3)
    floor = floor_envelope(tool, table, dexels, np.linspace(-0.9, 0.9, 7) * R)
    np.testing.assert_allclose(left, -(d @ y), atol=1e-9, rtol=0)
    np.testing.assert_allclose(right, d @ y, atol=1e-9, rtol=0)
    np.testing.assert_allclose(floor, d[2], atol=1e-9, rtol=0)


def test_constant_deflection_wall_independent_of_sample_spacing():
    tool = _straight(5e-6, 4e-3, lag=0.0)
    d = np.array([0.02, -0.03, 0.01]) * 1e-3
    table = _constant_table(np.tile(d, (tool.s.size, 1)))
    left = wall_envelope(tool, table, np.array([tool.s.size // 2]), 1, np.zeros((1, 1)), 1e-3)
    np.testing.assert_allclose(left, -d[1], atol=1e-9, rtol=0)


# -- 2./3. deflection varying over the revolution vs a brute-force sweep --------------------

A = np.array([0.0, 20.0, 4.0]) * UM
B = np.array([0.0, -10.0, -3.0]) * UM
C = np.array([0.0, -15.0, 8.0]) * UM
FEED_X = np.array([10.0, 0.0, 20.0]) * UM  # D_x = a cos 2psi + b sin 2psi + c


def _d(psi, dx=(0.0, 0.0, 0.0)):
    psi = np.asarray(psi)[..., None]
    out = A * np.cos(2 * psi) + B * np.sin(2 * psi) + C
    out[..., 0] += dx[0] * np.cos(2 * psi[..., 0]) + dx[1] * np.sin(2 * psi[..., 0]) + dx[2]
    return out


def _varying_setup(spacing=5e-6, m=360, dx=(0.0, 0.0, 0.0)):
    tool = _straight(spacing, 12e-3)  # the floor dexels are swept from R either side
    grid = np.arange(m) * (PITCH / m)
    table = DeflectionTable(0, np.repeat(_d(grid, dx)[None], tool.s.size, axis=0), PITCH)
    dexels = np.array([np.argmin(np.abs(tool.s - 6e-3)), np.argmin(np.abs(tool.s - 6.0175e-3))])
    return tool, table, dexels, PITCH / m


def _brute_wall(x_d, h, side, f, dx=(0.0, 0.0, 0.0), travel=1e-3, dpsi=5e-4):
    """Material left on the wall line x = x_d (wall nominal at y = side R) by the real
    cutter: centre at (x, 0) moving f per pitch, edge of tooth k at height h at
    centre + D(psi) + R (sin phi_k, cos phi_k), phi_k = psi + k pitch - lag h; the wall is the
    extreme y where an edge crosses x = x_d (linear interpolation between instants)."""
    psi = np.arange(0.0, 2 * travel / f * PITCH, dpsi)
    cx = x_d - travel + f * psi / PITCH
    d = _d(psi, dx)
    reach = []
    for k in range(2):
        phi = psi + k * PITCH - LAG * h
        x = cx + d[:, 0] + R * np.sin(phi) - x_d
        y = d[:, 1] + R * np.cos(phi)
        cross = (np.sign(x[:-1]) != np.sign(x[1:])) & (side * np.cos(phi[:-1]) > 0)
        w = x[:-1][cross] / (x[:-1][cross] - x[1:][cross])
        reach.append(side * (y[:-1][cross] + w * (y[1:][cross] - y[:-1][cross])))
    return R - np.max(np.concatenate(reach))


@pytest.mark.parametrize(("side", "dx"), [
    (1, (0.0, 0.0, 0.0)), (-1, (0.0, 0.0, 0.0)),
    (1, FEED_X), (-1, FEED_X)])
def test_wall_with_varying_deflection_matches_brute_force_sweep(side, dx):
    f = 5e-6  # feed per tooth
    tool, table, dexels, step = _varying_setup(dx=dx)
    dexels = dexels if not any(dx) else dexels[:1]
    heights = np.array([0.0, 3e-3, 7e-3])
    got = wall_envelope(tool, table, dexels, side, np.tile(heights, (dexels.size, 1)), 1e-3)
    want = np.array([[_brute_wall(tool.s[i], h, side, f, dx) for h in heights] for i in dexels])
    d2 = 4 * np.linalg.norm(A[1:2] + 1j * B[1:2])  # max |D_y''|
    tol = ((f**2 + (tool.s[1] - tool.s[0])**2) / (8 * R)  # feed marks, module's sampling
           + d2 * step**2 / 8  # table interpolation
           + (R + d2) * 5e-4**2 / 8)  # brute force: interpolation between instants
    np.testing.assert_allclose(got, want, atol=1.5 * tol, rtol=0)
    # the neighbouring passes matter here: far from the edge-normal value -side D_y(lag h)
    naive = -side * _d(LAG * heights)[:, 1]
    assert np.max(np.abs(got - naive)) > 20 * tol


def _brute_floor(x_q, lam, f, dpsi=0.01):
    """Floor at (x_q, lam) swept by the end edges (radial segments at phi_k = psi + k pitch)
    of the cutter moving f per pitch: min of D_z at the instants an edge passes over it."""
    psi = np.arange(0.0, 2 * R / f * PITCH, dpsi)
    dx = x_q - (x_q - R + f * psi / PITCH)
    theta = np.arctan2(dx, lam)
    inside = dx**2 + lam**2 < R**2
    found = []
    for k in range(2):
        w = np.angle(np.exp(1j * (theta - psi - k * PITCH)))
        cross = ((np.sign(w[:-1]) != np.sign(w[1:])) & (np.abs(w[:-1]) < 1)
                 & (np.abs(w[1:]) < 1) & inside[:-1] & inside[1:])
        t = w[:-1][cross] / (w[:-1][cross] - w[1:][cross])
        found.append(_d(psi[:-1][cross] + t * dpsi)[:, 2])
    return np.min(np.concatenate(found))


def test_floor_with_varying_deflection_matches_brute_force_sweep():
    f = 5e-6
    tool, table, dexels, step = _varying_setup()
    offsets = np.array([-0.8, -0.5, 0.0, 0.5, 0.8]) * R
    got = floor_envelope(tool, table, dexels, offsets)
    want = np.array([[_brute_floor(tool.s[i], lam, f) for lam in offsets] for i in dexels])
    dz1 = 2 * abs(A[2] + 1j * B[2])  # max |D_z'|
    # the deepest pass may sit where the disc's rim leaves the dexel, there the polar angle
    # moves lambda / R^2 per length of travel: error |D_z'| (f + spacing) |lambda| / R^2
    tol = (dz1 * (f + (tool.s[1] - tool.s[0])) * np.abs(offsets) / R**2
           + 2 * dz1 * step**2 / 8 + 1e-12)
    assert np.all(np.abs(got - want) < 1.5 * tol), (got - want, tol)
    # only part of the revolution passes over a dexel: 6.24 / 3.40 / 4 um (min of D_z 3 um)
    np.testing.assert_allclose(got[0], [6.24e-6, 3.402e-6, 4e-6, 3.402e-6, 6.24e-6], atol=1e-8)


# -- 4. samples that do not cut, or at another level, do not sweep ---------------------------

def test_non_cutting_samples_do_not_sweep():
    tool = _straight(0.1e-3, 40e-3)
    good, bad = np.array([0.02, -0.03, 0.01]) * 1e-3, np.array([0.1, 0.5, -0.5]) * 1e-3
    cutting = np.arange(tool.s.size) % 2 == 0
    d = np.where(cutting[:, None], good, bad)
    tool = SweptTool(tool.centres, tool.frames, tool.s, cutting, R, PITCH, LAG)
    dexels = _inner(tool, 3)
    dexels = dexels[cutting[dexels]]  # (a non-cutting dexel's sample is cut 0.1 mm away)
    heights = np.tile([0.0, 4e-3], (dexels.size, 1))
    table = _constant_table(d)
    np.testing.assert_allclose(wall_envelope(tool, table, dexels, 1, heights, 1e-3), -good[1],
                               atol=1e-9, rtol=0)
    np.testing.assert_allclose(wall_envelope(tool, table, dexels, -1, heights, 1e-3), good[1],
                               atol=1e-9, rtol=0)
    np.testing.assert_allclose(floor_envelope(tool, table, dexels, np.array([-3e-3, 0, 3e-3])),
                               good[2], atol=1e-9, rtol=0)


@pytest.mark.parametrize(("rise", "counted"), [(5e-3, False), (5e-6, True)])
def test_second_pass_at_another_level_does_not_sweep(rise, counted):
    """Along x to 20 mm at z = 0, up ``rise``, back along x: near the turn the second pass is
    within the arc-length window of the first pass's dexels."""
    step = 0.1e-3
    x1 = np.arange(0.0, 20e-3 + step / 2, step)
    z_up = np.linspace(0.0, rise, 11)[1:]
    x2 = x1[::-1][1:]
    centres = np.vstack([np.column_stack([x1, 0 * x1, 0 * x1]),
                         np.column_stack([np.full(z_up.size, 20e-3), 0 * z_up, z_up]),
                         np.column_stack([x2, 0 * x2, np.full(x2.size, rise)])])
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(centres, axis=0), axis=1))]
    n = s.size
    tool = SweptTool(centres, np.tile(np.eye(3), (n, 1, 1)), s, np.ones(n, bool), R, PITCH, LAG)
    good, bad = np.array([0.02, -0.03, 0.01]) * 1e-3, np.array([0.0, 0.5, -0.5]) * 1e-3
    table = _constant_table(np.where(centres[:, 2:] > 0, bad, good))
    dexels = np.flatnonzero((x1 > 16e-3) & (x1 < 19.5e-3))
    heights = np.tile([0.0, 4e-3], (dexels.size, 1))
    left = wall_envelope(tool, table, dexels, 1, heights, 1e-3)
    floor = floor_envelope(tool, table, dexels, np.array([-3e-3, 0, 3e-3]))
    if counted:  # the control: at the same level (within SAME_LEVEL) the return pass sweeps
        assert left[-1, 0] < -0.4e-3 and np.all(floor[-1] < -0.4e-3)
    else:
        np.testing.assert_allclose(left, -good[1], atol=1e-9, rtol=0)
        np.testing.assert_allclose(floor, good[2], atol=1e-9, rtol=0)


# -- 5. the table ------------------------------------------------------------------------------

def test_table_interpolates_linearly_and_periodically():
    rng = np.random.default_rng(7)
    m, rows, first, pitch = 9, 4, 3, 2 * np.pi / 3
    values = rng.normal(size=(rows, m, 3))
    table = DeflectionTable(first, values, pitch)
    psi = np.r_[rng.uniform(-3 * pitch, 4 * pitch, 205), np.arange(-m, 2 * m) * (pitch / m)]
    k = first + rng.integers(0, rows, psi.size)
    got = table.at(k, psi)
    grid = np.arange(m) * (pitch / m)
    want = np.array([[np.interp(p, grid, values[r - first, :, c], period=pitch) for c in range(3)]
                     for p, r in zip(psi, k, strict=True)])
    np.testing.assert_allclose(got, want, atol=1e-12, rtol=0)
    # 2-d index arrays, as the envelope uses them
    np.testing.assert_allclose(table.at(k.reshape(8, -1), psi.reshape(8, -1)),
                               want.reshape(8, -1, 3), atol=1e-12, rtol=0)
