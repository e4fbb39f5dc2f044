"""The five-axis stock walk (feedopt.process.dexel_material) against an exact reference, with
its removal lagging behind (the default) and one sample behind, and its cost, back to back in
one process.

Paths of a 10 mm ball-nose through a box, at 0.2 mm samples and 0.1 mm rays:

* ``straight``: a 30 mm line at 10 deg lead, 1 mm below the top;
* ``arc``: a 90 deg arc of 8 mm radius at 10 deg lead, 1 mm below the top, tighter than any
  finishing pass (an earlier pose can reach the front's rim where the feed turns);
* ``level``: a 30 mm line at no lead, 0.5 mm below the top (a finishing pass: the front's
  chip is thin near the tip, where a just-cut surface is misread as cut).

For each, the walk with the default lag (``lag``) and with the removal one sample behind,
and an exact reference: per sample, the engagement (same slices and angles) in the half-space
below the top minus the balls swept by every earlier pose (distance to the segments between
the earlier ball centres < R; the shank stays above the top here), with no dexel at all.
Also the walk of ``level`` with ``TriDexel.contains`` looking every point up in all three
grids (as before the third grid was consulted only where the first two disagree), back to
back with the current one: seconds, and whether the engagement is identical.
Reported: seconds (best of ``--repeat``), and for the magnitude of the mean cutting force per
unit feed per tooth over the revolution (``side_average``) of the cutting samples, each
walk's largest and median relative difference from the reference; the removed volumes.

    .venv/bin/python benchmarks/bench_dexel_run.py [--repeat 2]
        [--out benchmarks/results/dexel_run.txt]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from feedopt.process.averages import side_average
from feedopt.process.coefficients import load_coefficients
from feedopt.process.cutter import SliceEngagement
from feedopt.process.dexel import TriDexel
from feedopt.process.dexel_material import ANGLES, BLOCK, SLICES, sweep_dexel
from feedopt.process.engagement import Engagement
from feedopt.process.tilted_engagement import tilted_slice_engagement
from feedopt.process.tool import load_tool

ROOT = Path(__file__).resolve().parent.parent
MM = 1e-3
LEAD = math.radians(10.0)


def _path(kind: str) -> SimpleNamespace:
    """Samples (tips, unit tangents, unit axes leaning 10 deg towards the feed, or none on
    ``level``, s)."""
    if kind in ("straight", "level"):
        s = np.arange(0.0, 30 * MM + 1e-12, 0.2 * MM)
        tangent = np.tile([1.0, 0.0, 0.0], (s.size, 1))
        pos = np.column_stack([s - 15 * MM, np.zeros(s.size), np.zeros(s.size)])
    else:
        radius = 8 * MM
        s = np.arange(0.0, 0.5 * math.pi * radius + 1e-12, 0.2 * MM)
        a = s / radius - 0.25 * math.pi
        pos = np.column_stack([radius * np.sin(a), radius * (1 - np.cos(a)) - 2 * MM,
                               np.zeros(s.size)])
        tangent = np.column_stack([np.cos(a), np.sin(a), np.zeros(s.size)])
    lead = 0.0 if kind == "level" else LEAD
    axis = math.sin(lead) * tangent + math.cos(lead) * np.array([0.0, 0.0, 1.0])
    return SimpleNamespace(position=pos, tangent=tangent, axis=axis, s=s)


def _top(kind: str) -> float:
    return 0.5 * MM if kind == "level" else 1 * MM


def _box(kind: str) -> TriDexel:
    return TriDexel.box([-20 * MM, -15 * MM, -8 * MM], [20 * MM, 15 * MM, _top(kind)],
                        0.1 * MM)


def _reference(tool, samples, depth: np.ndarray, top: float) -> Engagement:
    """The exact engagement of every sample (module docstring), sliced over ``depth``."""
    radius = 0.5 * tool.diameter
    centres = samples.position + radius * samples.axis
    los, his, parts = [], [], []
    for i in range(samples.s.size):
        # the earlier poses' balls: segments c_0 c_1, ..., c_{i-2} c_{i-1} (c_0 alone at i = 1)
        a, b = (centres[:i - 1], centres[1:i]) if i > 1 else (centres[:1], centres[:1])

        def contains(p, a=a, b=b, i=i):
            d = b - a
            dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-30)
            t = np.clip(np.einsum("pij,ij->pi", p[:, None] - a, d) / dd, 0.0, 1.0)
            near = np.min(np.sum((p[:, None] - a - t[..., None] * d) ** 2, axis=2), axis=1)
            return (p[:, 2] < top) & (near >= radius**2) if i else p[:, 2] < top

        te = tilted_slice_engagement(contains, samples.position[i], samples.axis[i],
                                     samples.tangent[i], tool.profile, depth[i], SLICES,
                                     ANGLES)
        los.append(te.slices.lo)
        his.append(te.slices.hi)
        parts.append(te)
    width = max(x.shape[2] for x in los)
    lo = np.concatenate([np.pad(x, ((0, 0), (0, 0), (0, width - x.shape[2]))) for x in los])
    hi = np.concatenate([np.pad(x, ((0, 0), (0, 0), (0, width - x.shape[2]))) for x in his])
    s0 = parts[0].slices.sliced
    sliced = type(s0)(*(np.concatenate([getattr(t.slices.sliced, f) for t in parts])
                        for f in ("radius", "height", "sin_kappa", "cos_kappa", "width")))
    fx = np.concatenate([t.feed_x for t in parts])
    fz = np.concatenate([t.feed_z for t in parts])
    n = samples.s.size
    return Engagement(np.zeros(n), np.full(n, math.pi), depth,
                      by_slice=SliceEngagement(sliced, lo, hi, fx, fz))


def _walk(tool, samples, kind: str, lag: int | None, repeat: int):
    best, out = math.inf, None
    for _ in range(repeat):
        box = _box(kind)
        before = box.volume()
        t0 = time.perf_counter()
        found = sweep_dexel(box, tool, samples, lag_samples=lag)
        best = min(best, time.perf_counter() - t0)
        out = (found, before - box.volume())
    return best, out


def _all_three(stock: TriDexel):
    """``stock.contains`` as it was: the three grids' votes summed for every point."""
    def contains(points, rule: str = "majority"):
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        lo, hi = stock.bounds()
        inside = np.flatnonzero(np.all((pts >= lo) & (pts < hi), axis=1))
        out = np.zeros(pts.shape[0], dtype=bool)
        votes = sum(g.contains(pts[inside]).astype(np.int64) for g in stock.grids)
        out[inside] = votes >= 2
        return out
    return contains


def _contains_lines(tool, repeat: int) -> str:
    samples = _path("level")
    times, tables = {}, {}
    for _ in range(repeat):
        for name in ("all three", "two then the third"):
            box = _box("level")
            if name == "all three":
                box.contains = _all_three(box)
            t0 = time.perf_counter()
            found = sweep_dexel(box, tool, samples)
            times[name] = min(times.get(name, math.inf), time.perf_counter() - t0)
            tables[name] = found.engagement.by_slice
    a, b = tables.values()
    same = np.array_equal(a.lo, b.lo) and np.array_equal(a.hi, b.hi)
    return ("contains on the level walk: " + ", ".join(f"{k} {v:.2f} s" for k, v in
                                                        times.items())
            + f"; engagement identical: {same}")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--out", type=Path)
    a = p.parse_args(argv)
    tool = load_tool(ROOT / "scenarios" / "tools" / "carbide_ball_10mm.yaml")
    coeffs = load_coefficients(ROOT / "scenarios" / "materials" / "6061-T6511.yaml").at(2500)
    lines = [f"# bench_dexel_run: ball 10 mm, 0.2 mm samples, 0.1 mm rays, blocks of {BLOCK}; "
             f"the removal lagging (default) vs one sample behind (best of {a.repeat})"]
    for kind in ("straight", "arc", "level"):
        samples = _path(kind)
        rows = {name: _walk(tool, samples, kind, lag, a.repeat)
                for name, lag in (("lag", None), ("one", 1))}
        (t_b, (f_b, v_b)), (t_1, (f_1, v_1)) = rows["lag"], rows["one"]
        cut = ~f_b.in_air & ~f_1.in_air
        ref = _reference(tool, samples, f_b.engagement.axial_depth, _top(kind))

        def mean(e, cut=cut):
            return np.linalg.norm(side_average(tool, coeffs, e)[0][cut], axis=1)

        m_ref = mean(ref)
        diff = {b: (mean(f.engagement) - m_ref) / m_ref
                for b, f in (("lagging", f_b), ("one behind", f_1))}
        lines.append(
            f"{kind:8s} {samples.s.size:4d} samples ({int(cut.sum())} cutting): lagging "
            f"{t_b:.2f} s ({1e3 * t_b / samples.s.size:.2f} ms/sample), one behind {t_1:.2f} s; "
            "mean cutting force per unit c against the exact reference: "
            + ", ".join(f"{b} lowest {d.min():+.2%} highest {d.max():+.2%} median "
                        f"{np.median(d):+.2%}" for b, d in diff.items())
            + f"; removed {v_b / MM**3:.2f} vs {v_1 / MM**3:.2f} mm^3")
    lines.append(_contains_lines(tool, a.repeat))
    text = "\n".join(lines)
    print(text)
    if a.out is not None:
        a.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
