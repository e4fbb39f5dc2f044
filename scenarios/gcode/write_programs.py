"""Write the bundled G-code programs ``pocket.nc`` and ``profile.nc`` (and a benchmark chain).

The programs are written the way a Fanuc-style 3-axis mill post-processor (Fusion 360, Haas,
Fanuc posts) writes them: ``%``, an O number, N numbers on every block, a safety line, modal
G codes, axis words and feeds (only what changed is written, so bare coordinate lines continue
a G1), IJK arcs with the centre incremental from the arc start (the Fanuc default), a few R-word
arcs, and decimal numbers with a trailing point (``X12.5 Y-3.``). They are not the output of a
commercial CAM system: this script computes the tool-centre paths itself (see README.md).

Running ``python scenarios/gcode/write_programs.py`` rewrites both files in this directory,
byte-identically: the paths are computed with the standard library only (``math``), every
coordinate is rounded to 4 decimals when written. :func:`freeform_chain_program` (numpy) gives a
long free-form chain for benchmarks; it is not written by default.

Conventions (both programs): millimetres, feeds in mm/min (G94), G54 origin = workpiece frame W
origin on the TOP face of the stock, Z up along the tool axis, material below Z0. Tool T1: a
19.05 mm 2-flute flat end mill (``scenarios/tools/hss_2flute_19mm.yaml``), S2500 M3 (clockwise),
climb milling (material on the right of the feed direction).
"""

from __future__ import annotations

import bisect
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

# ----------------------------------------------------------------------------- common data
TOOL_DIAMETER_MM = 19.05
TOOL_RADIUS_MM = TOOL_DIAMETER_MM / 2.0  # 9.525
SPINDLE_RPM = 2500
FEED_CUT = 254.0  # mm/min = 4.23 mm/s, peripheral passes
FEED_ENTRY = 200.0  # mm/min, helix and ramp entries
FEED_PLUNGE = 300.0  # mm/min, straight plunge in air only (above Z0)
CLEARANCE_Z = 5.0
SAFE_Z = 25.0
FEED_HEIGHT_Z = 0.5  # plunge in air stops here; entries into material start here

# Pocket (program O1001)
POCKET_CENTRE = (60.0, 40.0)
POCKET_SIZE = (120.0, 80.0)
POCKET_CORNER_R = 15.0
POCKET_LEVELS = (-1.5, -3.0)
POCKET_STEPOVER = 0.5 * TOOL_DIAMETER_MM  # 9.525
POCKET_MIN_CORNER_R = 1.0  # smallest tool-centre corner radius of the inner passes
HELIX_R = 5.0
HELIX_MAX_PITCH = 0.8  # mm of Z per turn
POCKET_STOCK = ((-20.0, -20.0, -25.0), (140.0, 100.0, 0.0))

# Profile (program O1002): part outline, see profile_outline_description()
PROFILE_Z = -1.5
PROFILE_STOCK = ((-10.0, -10.0, -20.0), (140.0, 100.0, 0.0))
FREEFORM_X = (10.0, 80.0)  # the free-form stretch of the top edge spans these x
FREEFORM_BASE_Y = 90.0
FREEFORM_AMPLITUDE = 12.0  # y = 90 + A sin^2(pi u) cos(pi u), u = (x - 10) / 70
FREEFORM_TOLERANCE = 0.002  # chord error of the discretised tool-centre curve [mm]
FREEFORM_SEGMENT = (0.2, 0.5)  # shortest, longest G1 segment of it [mm]
LEAD_R = 5.0  # profile lead-in / lead-out arc radius
RAMP_LENGTH = 11.5  # profile ramp: 2 mm of Z over 11.5 mm (about 10 degrees)


# ----------------------------------------------------------------------------- the "post"
def fmt(value: float) -> str:
    """A number as a Fanuc post writes it: 4 decimals, trailing zeros cut, trailing point."""
    text = f"{value:.4f}".rstrip("0")
    if text in ("-0.", "0.", "-."):
        return "0."
    return text


class _Post:
    """Writes blocks with modal G, axis and feed words, like a post-processor."""

    def __init__(self, n_step: int = 10) -> None:
        self.lines: list[str] = []
        self.n = 0
        self.n_step = n_step
        self.motion: str | None = None
        self.pos: list[str | None] = [None, None, None]
        self.feed: str | None = None

    # raw output
    def text(self, line: str) -> None:
        self.lines.append(line)

    def comment(self, text: str) -> None:
        self.lines.append(f"({text})")

    def block(self, *words: str) -> None:
        self.n += self.n_step
        if self.n > 99999:  # Fanuc: 5-digit sequence numbers, wrap around
            self.n = self.n_step
        self.lines.append(" ".join((f"N{self.n}", *[w for w in words if w])))

    def forget_position(self, axes: str = "XYZ") -> None:
        for a in axes:
            self.pos["XYZ".index(a)] = None

    def forget_motion(self) -> None:
        self.motion = None

    # modal words
    def _g(self, code: str) -> str:
        if code == self.motion:
            return ""
        self.motion = code
        return code

    def _axes(self, x: float | None, y: float | None, z: float | None) -> list[str]:
        out = []
        for i, (letter, v) in enumerate(zip("XYZ", (x, y, z), strict=True)):
            if v is None:
                continue
            s = fmt(v)
            if s != self.pos[i]:
                out.append(letter + s)
                self.pos[i] = s
        return out

    def _f(self, feed: float | None) -> str:
        if feed is None:
            return ""
        s = fmt(feed)
        if s == self.feed:
            return ""
        self.feed = s
        return "F" + s

    def position(self) -> tuple[float, float, float]:
        """The last written position (rounded as written)."""
        if any(p is None for p in self.pos):
            raise RuntimeError("position not known")
        return (float(self.pos[0]), float(self.pos[1]), float(self.pos[2]))  # type: ignore[arg-type]

    # motions
    def rapid(self, x: float | None = None, y: float | None = None, z: float | None = None,
              *pre: str) -> None:
        words = self._axes(x, y, z)
        if words:
            self.block(*pre, self._g("G0"), *words)

    def line(self, x: float | None = None, y: float | None = None, z: float | None = None,
             feed: float | None = None, note: str = "") -> None:
        words = self._axes(x, y, z)
        if not words:
            return
        f = self._f(feed)
        g = self._g("G1")
        self.block(g, *words, f)
        if note:
            self.lines[-1] += f" ({note})"

    def arc(self, ccw: bool, x: float, y: float, z: float | None, cx: float, cy: float,
            feed: float | None = None, use_r: bool = False) -> None:
        """XY arc (G17) from the current position to (x, y[, z]) about (cx, cy)."""
        sx, sy, _ = self.position()
        g = self._g("G3" if ccw else "G2")
        if use_r:
            r = math.hypot(x - cx, y - cy)
            # + R for sweeps up to 180 degrees, - R beyond (this script only uses + R)
            a0 = math.atan2(sy - cy, sx - cx)
            a1 = math.atan2(y - cy, x - cx)
            sweep = ((a1 - a0) if ccw else (a0 - a1)) % (2.0 * math.pi)
            rw = "R" + fmt(r if sweep <= math.pi else -r)
            words = self._axes(x, y, z)
            self.block(g, *words, rw, self._f(feed))
            return
        i = cx - sx
        j = cy - sy
        words = self._axes(x, y, z)
        self.block(g, *words, "I" + fmt(i), "J" + fmt(j), self._f(feed))


def _header(post: _Post, number: int, name: str, lines: list[str]) -> None:
    post.text("%")
    post.text(f"O{number} ({name})")
    post.comment("WRITTEN BY FEEDOPT SCENARIOS/GCODE/WRITE_PROGRAMS.PY - NOT BY A COMMERCIAL "
                 "CAM SYSTEM")
    post.comment("IMITATES THE OUTPUT OF A FANUC-STYLE 3-AXIS MILL POST")
    for line in lines:
        post.comment(line)


def _start(post: _Post, x: float, y: float, comment: str) -> None:
    """Safety line, tool change, spindle, work offset, first rapid, tool length offset."""
    post.block("G21 G17 G90 G94 G40 G49 G80")
    post.text("; T1 - 19.05 MM FLAT END MILL")
    post.block("T1 M6")
    post.forget_position()
    post.block(f"S{SPINDLE_RPM} M3")
    post.block("M8")
    post.block("G54")
    post.comment(comment)
    post.rapid(x, y)
    post.block("G43 H1 " + "Z" + fmt(SAFE_Z))
    post.pos[2] = fmt(SAFE_Z)
    post.rapid(z=CLEARANCE_Z)


def _end(post: _Post) -> None:
    post.rapid(z=SAFE_Z)
    post.block("M5")
    post.block("M9")
    post.block("G28 G91 Z0.")
    post.block("G90")
    post.block("M30")
    post.text("%")


# ----------------------------------------------------------------------------- pocket
def pocket_passes() -> list[tuple[float, float, float]]:
    """Tool-centre passes of one level, inside out: ``(half_x, half_y, corner_r)`` each.

    The outermost follows the wall at the tool radius (tool-centre corner radius 15 - 9.525);
    each inner one is offset inwards by the step-over, its corner radius clamped to 1 mm; a pass
    whose half-height would fall below that radius is not made.
    """
    hx0 = POCKET_SIZE[0] / 2.0 - TOOL_RADIUS_MM
    hy0 = POCKET_SIZE[1] / 2.0 - TOOL_RADIUS_MM
    r0 = POCKET_CORNER_R - TOOL_RADIUS_MM
    passes = []
    k = 0
    while True:
        d = k * POCKET_STEPOVER
        hx, hy = hx0 - d, hy0 - d
        r = max(r0 - d, POCKET_MIN_CORNER_R)
        if hy < r:
            break
        passes.append((hx, hy, r))
        k += 1
    return passes[::-1]


def _rounded_rect_ccw(post: _Post, hx: float, hy: float, r: float) -> None:
    """One counter-clockwise pass from (and back to) the middle of the +X side."""
    cx, cy = POCKET_CENTRE
    post.line(cx + hx, cy + hy - r)
    post.arc(True, cx + hx - r, cy + hy, None, cx + hx - r, cy + hy - r)
    post.line(cx - hx + r, cy + hy)
    post.arc(True, cx - hx, cy + hy - r, None, cx - hx + r, cy + hy - r)
    post.line(cx - hx, cy - hy + r)
    post.arc(True, cx - hx + r, cy - hy, None, cx - hx + r, cy - hy + r)
    post.line(cx + hx - r, cy - hy)
    post.arc(True, cx + hx, cy - hy + r, None, cx + hx - r, cy - hy + r)
    post.line(cx + hx, cy)


def _helix(post: _Post, z_top: float, z_bottom: float) -> int:
    """Counter-clockwise helix about the pocket centre in half turns, then a flat turn."""
    cx, cy = POCKET_CENTRE
    turns = math.ceil((z_top - z_bottom) / HELIX_MAX_PITCH - 1e-9)
    halves = 2 * turns
    for k in range(1, halves + 1):
        z = z_top + (z_bottom - z_top) * k / halves
        x = cx - HELIX_R if k % 2 else cx + HELIX_R
        post.arc(True, x, cy, z, cx, cy, FEED_ENTRY if k == 1 else None)
    post.arc(True, cx - HELIX_R, cy, None, cx, cy)
    post.arc(True, cx + HELIX_R, cy, None, cx, cy)
    return turns


def pocket_program() -> str:
    """The text of ``pocket.nc``."""
    cx, cy = POCKET_CENTRE
    passes = pocket_passes()
    (sx0, sy0, sz0), (sx1, sy1, sz1) = POCKET_STOCK
    post = _Post()
    _header(post, 1001, "POCKET", [
        "UNITS MM - FEEDS MM/MIN - WORK OFFSET G54",
        "G54 ORIGIN = WORKPIECE FRAME W: POCKET CORNER X0 Y0 ON THE TOP FACE OF THE STOCK,",
        "Z UP = TOOL AXIS, MATERIAL BELOW Z0",
        f"STOCK X{fmt(sx0)} Y{fmt(sy0)} Z{fmt(sz0)} TO X{fmt(sx1)} Y{fmt(sy1)} Z{fmt(sz1)} - "
        "ALUMINIUM 6061",
        f"T1 D={fmt(TOOL_DIAMETER_MM)} CR=0. - FLAT END MILL 2 FLUTES - "
        f"ZMIN={fmt(POCKET_LEVELS[-1])}",
        f"POCKET {fmt(POCKET_SIZE[0])} X {fmt(POCKET_SIZE[1])} CORNER R{fmt(POCKET_CORNER_R)} "
        f"CENTRE X{fmt(cx)} Y{fmt(cy)} - DEPTH {fmt(-POCKET_LEVELS[-1])} IN "
        f"{len(POCKET_LEVELS)} LEVELS",
        f"HELIX R{fmt(HELIX_R)} MAX {fmt(HELIX_MAX_PITCH)} MM PER TURN - OFFSET PASSES INSIDE OUT "
        f"STEPOVER {fmt(POCKET_STEPOVER)} - CLIMB CCW",
    ])
    hx_in = passes[0][0]
    _start(post, cx + HELIX_R, cy, "POCKET1")
    for level, z in enumerate(POCKET_LEVELS, start=1):
        post.text(f"; LEVEL {level} OF {len(POCKET_LEVELS)} Z{fmt(z)}")
        if level > 1:
            post.rapid(z=CLEARANCE_Z)
            post.rapid(cx + HELIX_R, cy)
        post.line(z=FEED_HEIGHT_Z, feed=FEED_PLUNGE)
        _helix(post, FEED_HEIGHT_Z, z)
        post.line(cx + hx_in, cy, feed=FEED_CUT)
        for k, (hx, hy, r) in enumerate(passes):
            last = k == len(passes) - 1
            if k > 0 and not last:
                post.line(cx + hx, cy)  # straight step outwards
            if last:
                # tangent lead-in arc onto the wall pass, quarter arc of half the step-over
                rho = 0.5 * POCKET_STEPOVER
                post.line(cx + hx - rho, cy - rho)
                post.arc(True, cx + hx, cy, None, cx + hx - rho, cy, use_r=True)
            _rounded_rect_ccw(post, hx, hy, r)
            if last:
                rho = 0.5 * POCKET_STEPOVER
                post.arc(True, cx + hx - rho, cy + rho, None, cx + hx - rho, cy, use_r=True)
    _end(post)
    return "\n".join(post.lines) + "\n"


# ----------------------------------------------------------------------------- profile
def freeform_y(x: float) -> tuple[float, float, float]:
    """Top edge of the part over the free-form stretch: y(x), y'(x), y''(x)."""
    x0, x1 = FREEFORM_X
    L = x1 - x0
    u = (x - x0) / L
    a = math.pi * u
    s, c = math.sin(a), math.cos(a)
    # f = s^2 c ; f' = pi (2 s c^2 - s^3) ; f'' = pi^2 (2 c^3 - 7 s^2 c)
    f = s * s * c
    f1 = math.pi * (2.0 * s * c * c - s ** 3)
    f2 = math.pi ** 2 * (2.0 * c ** 3 - 7.0 * s * s * c)
    A = FREEFORM_AMPLITUDE
    return FREEFORM_BASE_Y + A * f, A * f1 / L, A * f2 / (L * L)


def _freeform_offset(x: float) -> tuple[float, float, float]:
    """Tool-centre point above the free-form at parameter x, and its signed curvature."""
    y, y1, y2 = freeform_y(x)
    w = math.hypot(1.0, y1)
    nx, ny = -y1 / w, 1.0 / w  # left of the +X travel = outside the part
    k = y2 / w ** 3  # > 0 turns left (concave for this clockwise contour)
    ko = k / (1.0 - TOOL_RADIUS_MM * k)
    return x + TOOL_RADIUS_MM * nx, y + TOOL_RADIUS_MM * ny, ko


def freeform_points() -> list[tuple[float, float]]:
    """The tool-centre free-form stretch, discretised like CAM output of a spline.

    Segment lengths follow the curvature (``sqrt(8 rho tol)`` for the chord error ``tol``),
    clamped to 0.2..0.5 mm and evened out over the stretch.
    """
    x0, x1 = FREEFORM_X
    n = 14000
    xs = [x0 + (x1 - x0) * i / n for i in range(n + 1)]
    pts = [_freeform_offset(x) for x in xs]
    s = [0.0]
    for (ax, ay, _), (bx, by, _) in zip(pts, pts[1:], strict=False):
        s.append(s[-1] + math.hypot(bx - ax, by - ay))
    lo, hi = FREEFORM_SEGMENT
    h = [min(hi, max(lo, math.sqrt(8.0 * FREEFORM_TOLERANCE / max(abs(k), 1e-12))))
         for _, _, k in pts]
    phi = [0.0]
    for i in range(n):
        phi.append(phi[-1] + (s[i + 1] - s[i]) * 0.5 * (1.0 / h[i] + 1.0 / h[i + 1]))
    m = math.ceil(phi[-1])
    out = []
    for k in range(m + 1):
        target = phi[-1] * k / m
        i = min(max(bisect.bisect_right(phi, target) - 1, 0), n - 1)
        t = (target - phi[i]) / (phi[i + 1] - phi[i])
        x = xs[i] + t * (xs[i + 1] - xs[i])
        px, py, _ = _freeform_offset(x)
        out.append((px, py))
    out[0] = (x0, FREEFORM_BASE_Y + TOOL_RADIUS_MM)
    out[-1] = (x1, FREEFORM_BASE_Y + TOOL_RADIUS_MM)
    return out


def profile_program() -> str:
    """The text of ``profile.nc``."""
    R = TOOL_RADIUS_MM
    z = PROFILE_Z
    (sx0, sy0, sz0), (sx1, sy1, sz1) = PROFILE_STOCK
    post = _Post()
    _header(post, 1002, "PROFILE", [
        "UNITS MM - FEEDS MM/MIN - WORK OFFSET G54",
        "G54 ORIGIN = WORKPIECE FRAME W: PART CORNER X0 Y0 ON THE TOP FACE OF THE STOCK,",
        "Z UP = TOOL AXIS, MATERIAL BELOW Z0",
        f"STOCK X{fmt(sx0)} Y{fmt(sy0)} Z{fmt(sz0)} TO X{fmt(sx1)} Y{fmt(sy1)} Z{fmt(sz1)} - "
        "ALUMINIUM 6061",
        f"T1 D={fmt(TOOL_DIAMETER_MM)} CR=0. - FLAT END MILL 2 FLUTES - ZMIN={fmt(z)}",
        f"OUTSIDE PROFILE - ONE PASS AT Z{fmt(z)} - TOOL CENTRE {fmt(R)} OUTSIDE THE PART - "
        "CLIMB CW",
        f"FREE-FORM STRETCH X{fmt(FREEFORM_X[0])} TO X{fmt(FREEFORM_X[1])} AS G1 SEGMENTS "
        f"{fmt(FREEFORM_SEGMENT[0])} TO {fmt(FREEFORM_SEGMENT[1])} - TOLERANCE "
        f"{fmt(FREEFORM_TOLERANCE)}",
    ])
    # contour start: middle of the left edge (part x = 0), travelling +Y (clockwise)
    x_left = -R
    y_start = 45.0
    ax, ay = x_left - LEAD_R, y_start - LEAD_R  # lead-in arc start
    _start(post, ax - RAMP_LENGTH, ay, "PROFILE1")
    post.line(z=FEED_HEIGHT_Z, feed=FEED_PLUNGE)
    post.line(ax, ay, z, feed=FEED_ENTRY, note="RAMP")
    post.arc(True, x_left, y_start, None, ax, y_start, FEED_CUT, use_r=True)
    post.text("; CONTOUR")
    post.line(x_left, 80.0)
    post.arc(False, 10.0, 90.0 + R, None, 10.0, 80.0)
    pts = freeform_points()
    for px, py in pts[1:]:
        post.line(px, py)
    post.arc(False, 90.0 + R, 80.0, None, 80.0, 80.0)
    post.line(90.0 + R, 65.0)
    post.arc(True, 110.0, 45.0 + R, None, 110.0, 65.0)  # concave R20 -> R10.475
    post.line(120.0, 45.0 + R)
    post.arc(False, 130.0 + R, 35.0, None, 120.0, 35.0)
    post.line(130.0 + R, 10.0)
    post.arc(False, 120.0, -R, None, 120.0, 10.0)
    post.line(10.0, -R)
    post.arc(False, -R, 10.0, None, 10.0, 10.0)
    post.line(-R, y_start)
    post.arc(True, ax, y_start + LEAD_R, None, ax, y_start, use_r=True)
    _end(post)
    return "\n".join(post.lines) + "\n"


# ----------------------------------------------------------------------------- benchmark
def freeform_chain_program(n_moves: int = 20000, seed: int = 0) -> str:
    """A program with one long tangent-continuous free-form chain of ``n_moves`` G1 moves.

    The chain is a closed-looking, never-repeating curve at Z-1.5 in about X7..113, Y3..77:
    polar radius ``33 + sum of three slow sines`` of the angle (phases and amplitudes from
    ``seed``), scaled 1.2 in X and 0.85 in Y; the move lengths vary smoothly between 0.06 and
    0.98 mm. Entered by a tangent ramp from Z0.5; for benchmarks (not written to disk).
    """
    if n_moves < 1:
        raise ValueError("n_moves must be >= 1")
    rng = np.random.default_rng(seed)
    phases = rng.uniform(0.0, 2.0 * np.pi, 4)
    amps = np.array([6.0, 2.0, 0.6]) * rng.uniform(0.8, 1.2, 3)
    freqs = np.array([1.7, 3.1, 4.9])

    def curve(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r = 33.0 + np.sin(np.multiply.outer(theta, freqs) + phases[:3]) @ amps
        return 60.0 + 1.2 * r * np.cos(theta), 40.0 + 0.85 * r * np.sin(theta)

    i = np.arange(n_moves)
    ds = 0.06 + 0.92 * (0.5 - 0.5 * np.cos(2.0 * np.pi * i / 733.0 + phases[3]))
    s_target = np.concatenate(([0.0], np.cumsum(ds)))
    # |dr/dtheta| >= about 0.85 * (33 - 9.5) = 20 mm/rad: theta_max bounds the length
    theta_max = s_target[-1] / 15.0 + 1.0
    theta = np.arange(0.0, theta_max, 1e-3)
    x, y = curve(theta)
    s = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))))
    if s[-1] < s_target[-1]:
        raise RuntimeError("free-form chain: parameter range too short")
    px, py = curve(np.interp(s_target, s, theta))
    tx, ty = px[1] - px[0], py[1] - py[0]
    tn = math.hypot(tx, ty)
    rx, ry = px[0] - RAMP_LENGTH * tx / tn, py[0] - RAMP_LENGTH * ty / tn
    post = _Post()
    _header(post, 1003, "FREEFORM CHAIN", [
        "UNITS MM - FEEDS MM/MIN - WORK OFFSET G54 - MATERIAL BELOW Z0",
        f"BENCHMARK: ONE FREE-FORM CHAIN OF {n_moves} G1 MOVES AT Z-1.5 - SEED {seed}",
    ])
    _start(post, rx, ry, "CHAIN")
    post.line(z=FEED_HEIGHT_Z, feed=FEED_PLUNGE)
    post.line(px[0], py[0], PROFILE_Z, feed=FEED_ENTRY, note="RAMP")
    post.line(px[1], py[1], feed=FEED_CUT)
    for k in range(2, n_moves + 1):
        post.line(float(px[k]), float(py[k]))
    _end(post)
    return "\n".join(post.lines) + "\n"


# ----------------------------------------------------------------------------- files
PROGRAMS = {"pocket.nc": pocket_program, "profile.nc": profile_program}


def main(out_dir: str | Path | None = None) -> list[Path]:
    """Write ``pocket.nc`` and ``profile.nc`` into ``out_dir`` (default: this directory)."""
    out = Path(out_dir) if out_dir is not None else HERE
    written = []
    for name, make in PROGRAMS.items():
        path = out / name
        path.write_bytes(make().encode("ascii"))
        written.append(path)
    return written


if __name__ == "__main__":
    for p in main(sys.argv[1] if len(sys.argv) > 1 else None):
        print(p)
