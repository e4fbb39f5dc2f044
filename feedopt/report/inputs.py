"""The job a report is about: an inputs table and the run's warnings, from ``summary.json``.

Built from the ``scenario`` section of ``summary.json`` alone (written by
:func:`feedopt.report.summary.scenario_summary`), so a report of an older run simply shows
fewer rows: a row whose numbers are missing is left out. Values are in user units with the
unit written.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

_MODES = {
    "norm": "norm of the TCP deflection",
    "normal": "component along the in-plane surface normal",
    "direction": "component along a given direction",
}


_AT_RPM = {
    "calibrated": "is a calibrated speed",
    "interpolated": "is interpolated linearly between calibrated speeds",
    "extrapolated": "is outside them: the nearest calibrated speed is held (extrapolation)",
}


def _g(x, fmt: str = "g") -> str:
    return format(float(x), fmt)


def _vec(v: Sequence, fmt: str = "g") -> str:
    return "(" + ", ".join(_g(x, fmt) for x in v) + ")"


def _robot(sc: Mapping) -> str | None:
    r = sc.get("robot")
    if not isinstance(r, Mapping) or not r.get("name"):
        return None
    return str(r["name"]) + (f" ({r['directory']})" if r.get("directory") else "")


def _stiffness(sc: Mapping) -> str | None:
    if sc.get("stiffness_set") is None or sc.get("stiffness_mnm_per_rad") is None:
        return None
    values = ", ".join(_g(k) for k in sc["stiffness_mnm_per_rad"])
    return f"{sc['stiffness_set']}: {values} MNm/rad (joints 1-{len(sc['stiffness_mnm_per_rad'])})"


def _stiffness_source(sc: Mapping) -> str | None:
    r = sc.get("robot")
    return r.get("stiffness_source") or None if isinstance(r, Mapping) else None


def _tcp(sc: Mapping) -> str | None:
    if sc.get("tcp_offset_mm") is None:
        return None
    return f"{_vec(sc['tcp_offset_mm'])} mm in the flange frame"


def _tool(sc: Mapping) -> str | None:
    t = sc.get("tool")
    if not isinstance(t, Mapping):
        return None
    parts = []
    if t.get("diameter_mm") is not None:
        parts.append(f"diameter {_g(t['diameter_mm'], '.4g')} mm")
    if t.get("teeth") is not None:
        parts.append(f"{t['teeth']} teeth")
    if t.get("helix_deg") is not None:
        parts.append(f"helix {_g(t['helix_deg'], '.4g')} deg")
    if t.get("shape") not in (None, "flat"):
        parts.append(f"{t['shape']}, corner radius {_g(t.get('corner_radius_mm'), '.4g')} mm"
                     + (f", taper {_g(t['taper_deg'], '.4g')} deg" if t.get("taper_deg") else ""))
    parts += _bending(t.get("bending"))
    name = str(t.get("name") or "")
    return f"{name}: {', '.join(parts)}" if name and parts else (name or ", ".join(parts))


def _bending(b) -> list[str]:
    """The tool's bending in the tool row: its stiffness and share of the deflection."""
    if not isinstance(b, Mapping) or b.get("lateral_stiffness_n_per_um") is None:
        return []
    out = [f"bends at {_g(b['lateral_stiffness_n_per_um'], '.3g')} N/um ({b.get('model')})"]
    share = b.get("share_of_mean_deflection")
    if isinstance(share, Mapping) and share.get("median") is not None:
        out.append(f"{100 * share['median']:.0f} % of the mean deflection is the tool's "
                   f"(median; {100 * share['at_largest']:.0f} % where it is largest)")
    return out


def _material(sc: Mapping) -> str | None:
    m = sc.get("material")
    if not isinstance(m, Mapping):
        return None
    return str(m.get("name") or m.get("file") or "") or None


def _coefficients(sc: Mapping) -> str | None:
    m = sc.get("material")
    if not isinstance(m, Mapping):
        return None
    out = str(m.get("coefficient_source") or "source not stated in the material file")
    speeds = ", ".join(_g(r) for r in m.get("calibrated_rpm") or [])
    if speeds:
        out += f"; calibrated at {speeds} rpm"
    how = _AT_RPM.get(str(m.get("coefficients_at_rpm")))
    rpm = (sc.get("cut") or {}).get("rpm")
    if how and rpm is not None:
        out += f"; {_g(rpm)} rpm {how}"
    return out


def _cut(key: str) -> Callable[[Mapping], str | None]:
    def get(sc: Mapping) -> str | None:
        c = sc.get("cut")
        if not isinstance(c, Mapping) or key not in c:
            return None
        if c.get(key) is None and (key != "radial_depth_mm" or c.get("type") is None):
            return None  # not stated (the engagement comes from the stock)
        if key == "rpm":
            return f"{_g(c['rpm'])} rpm"
        if key == "axial_depth_mm":
            return f"{_g(c['axial_depth_mm'])} mm"
        if key == "radial_depth_mm":
            return _radial(sc, c)
        return str(c[key])

    return get


def _radial(sc: Mapping, c: Mapping) -> str:
    if c.get("type") == "slot":
        d = (sc.get("tool") or {}).get("diameter_mm")
        return "full immersion (slot" + (f", {_g(d, '.4g')} mm" if d is not None else "") + ")"
    if c.get("radial_depth_mm") is not None:
        return f"{_g(c['radial_depth_mm'])} mm"
    prof = c.get("radial_depth_profile")
    if isinstance(prof, Mapping) and prof.get("depth_mm"):
        depth = " → ".join(_g(d) for d in prof["depth_mm"])
        if prof.get("s_mm") is not None:
            where = f"s = {' → '.join(_g(s) for s in prof['s_mm'])} mm"
        else:
            where = (f"s = {' → '.join(_g(s) for s in prof.get('s_fraction') or [])} x the "
                     "path length")
        return f"{depth} mm over {where} (linear in between)"
    return "-"


def _mm(key: str, unit: str, fmt: str = "g") -> Callable[[Mapping], str | None]:
    def get(sc: Mapping) -> str | None:
        return None if sc.get(key) is None else f"{_g(sc[key], fmt)} {unit}"

    return get


def _position(sc: Mapping) -> str | None:
    if sc.get("workpiece_position_mm") is None:
        return None
    return f"{_vec(sc['workpiece_position_mm'])} mm in the robot base frame"


def _rpy(sc: Mapping) -> str | None:
    if sc.get("workpiece_rpy_deg") is None:
        return None
    return f"{_vec(sc['workpiece_rpy_deg'])} deg (roll, pitch, yaw; extrinsic X-Y-Z)"


def _max_feed(sc: Mapping) -> str | None:
    if sc.get("max_feed_mm_s") is None:
        return None
    if isinstance(sc.get("program"), Mapping):
        if sc.get("max_feed_is_default"):
            return "the program's F of each move (rapids: the rapid limit)"
        return f"{_g(sc['max_feed_mm_s'])} mm/s on feed moves (replacing the program's F)"
    default = " (default: the nominal feed)" if sc.get("max_feed_is_default") else ""
    return f"{_g(sc['max_feed_mm_s'])} mm/s{default}"


def _limit(sc: Mapping) -> str | None:
    if sc.get("deflection_limit_mm") is None:
        return None
    out = f"{_g(sc['deflection_limit_mm'])} mm"
    mode = sc.get("limit_mode")
    if mode:
        out += f", mode {mode} ({_MODES.get(mode, mode)}"
        if mode == "direction" and sc.get("limit_direction") is not None:
            out += f" {_vec(sc['limit_direction'])}"
        out += ")"
    return out


def _samples(sc: Mapping) -> str | None:
    if sc.get("samples") is None:
        return None
    out = f"{int(sc['samples'])}"
    if sc.get("sample_spacing_mm") is not None:
        out += (f", spacing {_g(sc['sample_spacing_mm'], '.4g')} mm (path length / "
                "(samples - 1))")
    return out


def _path(sc: Mapping) -> str | None:
    if sc.get("path_length_mm") is None:
        return None
    out = f"{_g(sc['path_length_mm'], '.2f')} mm"
    p = sc.get("path")
    if isinstance(p, Mapping) and p.get("generator"):
        bits = [str(p["generator"])]
        if p.get("segments") is not None:
            bits.append(f"{p['segments']} segment{'' if p['segments'] == 1 else 's'}")
        if p.get("blend") and p["blend"] != "none":
            size = p.get("blend_size_mm")
            bits.append(f"{p['blend']} blends" + (f" {_g(size)} mm" if size is not None else ""))
        out += f" ({', '.join(bits)})"
    return out


def _nominal(sc: Mapping) -> str | None:
    """The nominal feed; for a program, its F words (the one reported covers most of it)."""
    v = sc.get("nominal_feed_mm_s")
    if v is None:
        return None
    if isinstance(sc.get("program"), Mapping):
        return f"the program's F per move ({_g(v)} mm/s over the longest stretch)"
    return f"{_g(v)} mm/s"


def _program(sc: Mapping) -> str | None:
    """A G-code program: moves, where the bound is lowest and the largest deviation."""
    p = sc.get("program")
    if not isinstance(p, Mapping):
        return None
    cats = p.get("moves_by_category") or {}
    out = f"{p.get('file')}: {p.get('moves')} moves (" + ", ".join(
        f"{v} {k}" for k, v in cats.items() if v) + ")"
    low = p.get("lowest_bound") or {}
    if low:
        out += (f"; feed bound lowest at {low.get('label')} ({_g(low.get('v_max_mm_s'))} "
                "mm/s)")
    dev = p.get("largest_deviation")
    if dev:
        out += (f"; largest deviation from the program {_g(dev.get('deviation_mm'))} mm at "
                f"{dev.get('junction')} (tolerance {_g(dev.get('tolerance_mm'))} mm)")
    return out


#: (label, formatter) of every row of the inputs table, in order.
ROWS: tuple[tuple[str, Callable[[Mapping], str | None]], ...] = (
    ("robot", _robot),
    ("joint stiffness", _stiffness),
    ("stiffness source", _stiffness_source),
    ("TCP offset", _tcp),
    ("tool", _tool),
    ("material", _material),
    ("cutting coefficients", _coefficients),
    ("spindle speed", _cut("rpm")),
    ("cut type", _cut("type")),
    ("axial depth", _cut("axial_depth_mm")),
    ("radial depth", _cut("radial_depth_mm")),
    ("milling", _cut("milling")),
    ("workpiece position", _position),
    ("workpiece orientation", _rpy),
    ("nominal feed", _nominal),
    ("max feed", _max_feed),
    ("deflection limit", _limit),
    ("tangential acceleration limit", _mm("tangential_acceleration_mm_s2", "mm/s^2")),
    ("tangential jerk limit", _mm("tangential_jerk_mm_s3", "mm/s^3")),
    ("samples", _samples),
    ("path length", _path),
    ("G-code program", _program),
)


def input_rows(summary: Mapping) -> list[tuple[str, str]]:
    """``(label, value)`` rows of the job in ``summary["scenario"]``; missing ones left out."""
    sc = summary.get("scenario")
    if not isinstance(sc, Mapping):
        return []
    rows = []
    for label, fmt in ROWS:
        try:
            value = fmt(sc)
        except (TypeError, ValueError, KeyError):  # a malformed entry: leave the row out
            value = None
        if value:
            rows.append((label, value))
    return rows


def run_warnings(summary: Mapping) -> list[str]:
    """The top-level ``warnings`` of ``summary.json`` (a list of strings), or none."""
    w = summary.get("warnings")
    if isinstance(w, str):
        return [w]
    if not isinstance(w, Sequence):
        return []
    return [str(x) for x in w if str(x).strip()]
