"""``feedopt calibrate-stiffness``: joint stiffness from static load tests (thesis 3.4).

``feedopt calibrate-stiffness TESTS.csv --robot DIR [--method cp|dpp] [--out FRAGMENT.yaml]``
identifies the joint stiffness (:func:`feedopt.robot.identification.identify`) and writes the
``joint_stiffness_mnm_per_rad`` block of ``robot.yaml``; ``feedopt calibrate-stiffness
--suggest N --robot DIR [--out TESTS.csv]`` plans the tests
(:func:`feedopt.robot.identification.suggest_poses`) and writes the CSV to fill in.
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import yaml

from feedopt.errors import InputError
from feedopt.outfile import check_output_file, write_atomically
from feedopt.robot.identification import (
    MAX_DISPLACEMENT_M,
    MAX_FORCE_N,
    MAX_MOMENT_NM,
    MAX_ROTATION_RAD,
    MAX_TESTS,
    LoadPlan,
    LoadTests,
    Method,
    PlanLoads,
    PoseCandidates,
    StiffnessIdentification,
    WarningKind,
    identify,
    repeat_groups,
    suggest_poses,
)
from feedopt.robot.model import RobotModel, load_robot
from feedopt.textio import read_user_text
from feedopt.units import MM

#: robot.yaml and this command give joint stiffness in MN m/rad.
_NM_PER_MNM = 1e6
_MRAD = 1e-3
FORCE_COLUMNS = ("fx_n", "fy_n", "fz_n")
MOMENT_COLUMNS = ("mx_nm", "my_nm", "mz_nm")
DISPLACEMENT_COLUMNS = ("dx_mm", "dy_mm", "dz_mm")
ROTATION_COLUMNS = ("drx_mrad", "dry_mrad", "drz_mrad")
#: Largest magnitude [unit of the column] of a static load test's value, by column.
_LIMITS: dict[str, tuple[float, str]] = {
    **{c: (MAX_FORCE_N, "N") for c in FORCE_COLUMNS},
    **{c: (MAX_MOMENT_NM, "N m") for c in MOMENT_COLUMNS},
    **{c: (MAX_DISPLACEMENT_M / MM, "mm") for c in DISPLACEMENT_COLUMNS},
    **{c: (MAX_ROTATION_RAD / _MRAD, "mrad") for c in ROTATION_COLUMNS},
}


def joint_columns(dof: int) -> tuple[str, ...]:
    """``q1_deg`` .. ``q<dof>_deg``."""
    return tuple(f"q{i}_deg" for i in range(1, dof + 1))


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register the ``calibrate-stiffness`` subcommand."""
    p = subparsers.add_parser(
        "calibrate-stiffness",
        epilog="docs: docs/calibration.md",
        help="identify joint stiffness from static load tests, or plan the tests",
        description=(
            "Identify the six joint stiffnesses (thesis 3.4) by linear least squares in the "
            "joint compliances from static load tests: a CSV with one row per pose and load, "
            "columns q1_deg..q6_deg,fx_n,fy_n,fz_n[,mx_nm,my_nm,mz_nm],dx_mm,dy_mm,dz_mm"
            "[,drx_mrad,dry_mrad,drz_mrad] (wrench applied at the TCP and TCP displacement / "
            "rotation vector measured, base frame; joint angles as in the robot's URDF; '#' "
            "comment lines allowed). --method cp fits all six at once (Eq. 3.19); dpp (the "
            "thesis's choice) fits the arm from the wrist-centre displacement, then the wrist "
            "(Eq. 3.20), and needs the rotations. Repeats of a test (same pose and load) are "
            "averaged and count once. Prints the stiffnesses with standard errors, "
            "the condition number and the residual of every test; --out writes the "
            "joint_stiffness_mnm_per_rad block for robot.yaml. Refuses (exit 2) tests that "
            "cannot identify a joint, naming it. With --suggest N, picks N non-singular poses "
            "that make the identification well conditioned (D-optimal) and --out writes them "
            "as a CSV to fill in with the measurements."
        ),
    )
    p.add_argument("tests_csv", nargs="?", metavar="TESTS.csv", help="load tests to identify from")
    p.add_argument("--robot", required=True, metavar="DIR", help="robot directory (robot.yaml "
                   "+ URDF): kinematics and TCP")
    p.add_argument("--method", choices=[m.value for m in Method], default=None,
                   help="cp (Eq. 3.19) or dpp (Eq. 3.20, default; needs rotations)")
    p.add_argument("--out", metavar="FILE", help="identification: write the robot.yaml "
                   "fragment (YAML); --suggest: write the test plan (CSV)")
    g = p.add_argument_group("planning the tests (--suggest)")
    g.add_argument("--suggest", type=int, metavar="N", help="suggest N test poses")
    g.add_argument("--seed", type=int, help="random seed of the candidate poses (default 0)")
    g.add_argument("--load-n", type=float, help="test force [N] (default 1000), applied along "
                   "base +x, +y and -z at every pose")
    g.add_argument("--lever-mm", type=float, help="the force acts this far from the TCP along "
                   "the tool frame's x axis [mm] (default 200): the moment about the tool axis "
                   "that identifies joint 6 of a coaxial tool")
    g.add_argument("--candidates", type=int, help="random candidate poses (default 2000)")
    g.add_argument("--translations-only", action="store_true", help="plan for a tracker that "
                   "measures the TCP position only (no rotations; DPP then impossible)")
    p.set_defaults(func=run)


_SUGGEST_ONLY = ("seed", "load_n", "lever_mm", "candidates")


def run(args: argparse.Namespace) -> int:
    """Identify, or with ``--suggest`` plan; returns 0."""
    if args.suggest is not None:
        if args.tests_csv is not None:
            raise InputError(f"give either TESTS.csv (identify) or --suggest N (plan), not "
                             f"both: {args.tests_csv} and --suggest {args.suggest}")
        if args.method is not None:
            raise InputError("--method applies to identification, not to --suggest")
        return _suggest(args)
    if args.tests_csv is None:
        raise InputError("give the load tests CSV (feedopt calibrate-stiffness TESTS.csv "
                         "--robot DIR) or --suggest N to plan them")
    given = [o for o in _SUGGEST_ONLY if getattr(args, o) is not None]
    if given or args.translations_only:
        opt = "--" + (given[0] if given else "translations_only").replace("_", "-")
        raise InputError(f"{opt} applies to --suggest only")
    return _identify(args)


# --------------------------------------------------------------------------- reading the CSV


def _data_lines(text: str) -> Iterator[tuple[int, str]]:
    """(line number, line) of every line that is not blank or a '#' comment, lazily."""
    for no, ln in enumerate(io.StringIO(text, newline=None), start=1):
        ln = ln.rstrip("\n")
        if ln.strip() and not ln.lstrip().startswith("#"):
            yield no, ln


def _expected_header(dof: int) -> str:
    return (",".join(joint_columns(dof) + FORCE_COLUMNS + MOMENT_COLUMNS + DISPLACEMENT_COLUMNS)
            + f"[,{','.join(ROTATION_COLUMNS)}]")


def _read_header(p: Path, no: int, line: str, dof: int) -> list[str]:
    """The column names of the header line, or InputError (unknown, repeated, missing)."""
    header = [h.strip() for h in next(csv.reader([line]))]
    required = joint_columns(dof) + FORCE_COLUMNS + DISPLACEMENT_COLUMNS
    known = set(required + MOMENT_COLUMNS + ROTATION_COLUMNS)
    for col in header:
        if col not in known:
            raise InputError(f"{p} line {no}: unknown column {col!r}; the columns are "
                             f"{_expected_header(dof)}")
        if header.count(col) > 1:
            raise InputError(f"{p} line {no}: column {col!r} is given twice")
    missing = [c for c in required if c not in header]
    for group in (MOMENT_COLUMNS, ROTATION_COLUMNS):
        present = [c for c in group if c in header]
        if present and len(present) < 3:
            missing += [c for c in group if c not in header]
    if missing:
        raise InputError(f"{p}: missing column(s) {', '.join(missing)}; expected header "
                         f"{_expected_header(dof)} (moments and rotations optional, all three "
                         "or none)")
    return header


def _parse_row(p: Path, no: int, line: str, header: list[str]) -> list[float]:
    """The numbers of one test row (NaN for an empty rotation cell), or InputError."""
    row = next(csv.reader([line]))
    if len(row) != len(header):
        raise InputError(f"{p} line {no}: {len(row)} values, the header has {len(header)}")
    out = []
    for col, raw in zip(header, row, strict=True):
        cell = raw.strip()
        if cell == "" and col in ROTATION_COLUMNS:
            out.append(math.nan)
            continue
        try:
            v = float(cell)
        except ValueError:
            hint = " (empty: fill in the measurement)" if cell == "" else ""
            raise InputError(f"{p} line {no}, column {col}: {cell!r} is not a number"
                             f"{hint}") from None
        if not math.isfinite(v):
            raise InputError(f"{p} line {no}, column {col}: {cell} is not finite")
        limit = _LIMITS.get(col)
        if limit is not None and abs(v) > limit[0]:
            raise InputError(f"{p} line {no}, column {col}: {cell} is beyond the {limit[0]:g} "
                             f"{limit[1]} of a static load test (a unit slip?)")
        out.append(v)
    if ROTATION_COLUMNS[0] in header:
        blank = [c for c, v in zip(header, out, strict=True)
                 if c in ROTATION_COLUMNS and math.isnan(v)]
        if 0 < len(blank) < 3:
            raise InputError(f"{p} line {no}: column {blank[0]} is empty; give all three "
                             "rotations of a test or none")
    return out


def _read_rows(p: Path, lines: Iterator[tuple[int, str]],
               header: list[str]) -> tuple[np.ndarray, list[int]]:
    """(rows, columns as in the header) of the tests and their line numbers; stops reading at
    the first row past :data:`MAX_TESTS` (a large file is refused before it is parsed)."""
    rows, numbers = [], []
    for no, line in lines:
        if len(rows) == MAX_TESTS:
            raise InputError(f"{p} line {no}: more than {MAX_TESTS} tests, the most read; a "
                             "few hundred are plenty (feedopt calibrate-stiffness --suggest)")
        rows.append(_parse_row(p, no, line, header))
        numbers.append(no)
    if not rows:
        raise InputError(f"load-test CSV {p} has a header but no tests")
    return np.array(rows, dtype=float), numbers


def read_load_tests(path: str | Path, robot: RobotModel) -> tuple[LoadTests, list[int]]:
    """Load tests (SI) from the CSV, and the file line of each test.

    InputError naming the file, line and column for a missing, unknown or repeated column, a
    value that is not a finite number or beyond a static load test's (:data:`_LIMITS`), a
    joint angle outside the robot's limits, a test with no load, a rotation given in part,
    more than :data:`MAX_TESTS` tests (refused at the first row past it).
    """
    p = Path(path)
    lines = _data_lines(read_user_text(p, "load-test CSV", encoding="utf-8-sig"))
    first = next(lines, None)
    if first is None:
        raise InputError(f"load-test CSV {p} is empty; expected a header "
                         f"{_expected_header(robot.dof)}")
    header = _read_header(p, *first, robot.dof)
    table, numbers = _read_rows(p, lines, header)
    values = dict(zip(header, table.T, strict=True))
    qcols = joint_columns(robot.dof)
    q = np.deg2rad(np.column_stack([values[c] for c in qcols]))
    out_of_range = (q < robot.q_lower) | (q > robot.q_upper)
    if out_of_range.any():
        r, j = map(int, np.argwhere(out_of_range)[0])
        raise InputError(
            f"{p} line {numbers[r]}, column {qcols[j]}: {values[qcols[j]][r]:g} deg is "
            f"outside joint {j + 1}'s limits [{np.rad2deg(robot.q_lower[j]):.1f}, "
            f"{np.rad2deg(robot.q_upper[j]):.1f}] deg of {robot.name}; are the angles in the "
            "convention of the robot's URDF?")
    forces = np.column_stack([values[c] for c in FORCE_COLUMNS])
    moments = (np.column_stack([values[c] for c in MOMENT_COLUMNS])
               if MOMENT_COLUMNS[0] in values else np.zeros_like(forces))
    wrench = np.hstack([forces, moments])
    unloaded = np.flatnonzero(~np.any(wrench != 0, axis=1))
    if unloaded.size:
        raise InputError(f"{p} line {numbers[unloaded[0]]}: the test has no load (force "
                         "and moment all zero), so it cannot tell any stiffness: remove it")
    disp = np.column_stack([values[c] for c in DISPLACEMENT_COLUMNS]) * MM
    rot = (np.column_stack([values[c] for c in ROTATION_COLUMNS]) * _MRAD
           if ROTATION_COLUMNS[0] in values else None)
    if rot is not None and np.isnan(rot).all():
        rot = None
    return LoadTests(q, wrench, disp, rot), numbers


# --------------------------------------------------------------------------- identification


def _fmt(values: np.ndarray) -> str:
    return "[" + ", ".join(f"{v:.6g}" for v in values) + "]"


def _count_tests(n_tests: int, n_distinct: int) -> str:
    """'30 load tests', or '30 load tests (12 distinct, repeats averaged)'."""
    if n_distinct == n_tests:
        return f"{n_tests} load tests"
    return f"{n_tests} load tests ({n_distinct} distinct, repeats averaged)"


def _print_noise(result: StiffnessIdentification) -> None:
    """The noise estimate of the fit and, with repeats, their repeatability."""
    sig, rep = result.sigma / np.array([MM, _MRAD]), result.repeatability / np.array([MM, _MRAD])
    if np.isfinite(sig[0]):
        noise = f"translation {sig[0]:.4g} mm" + (
            f", rotation {sig[1]:.4g} mrad" if np.isfinite(sig[1]) else "")
    else:
        noise = "not estimable"
    print(f"noise estimate from the residuals of the distinct tests: {noise} "
          f"({result.dof_residual} residual degrees of freedom)")
    if result.repeatability_dof:
        spread = f"translation {rep[0]:.4g} mm" + (
            f", rotation {rep[1]:.4g} mrad" if np.isfinite(rep[1]) else "")
        same = " (the repeats are identical to the last digit)" if not np.nanmax(rep) else ""
        print(f"repeatability (scatter of repeated tests about their means): {spread} "
              f"({result.repeatability_dof} degrees of freedom){same}")


def stiffness_fragment(result: StiffnessIdentification, source: str, n_tests: int,
                       n_poses: int, robot_name: str) -> str:
    """The ``joint_stiffness_mnm_per_rad`` block of ``robot.yaml`` (with comments)."""
    key = result.method.value
    k = result.stiffness / _NM_PER_MNM
    se = result.stiffness_se / _NM_PER_MNM
    eq = "3.20" if result.method is Method.DPP else "3.19"
    comments = (
        f"Joint stiffness of {' '.join(robot_name.split())} identified by feedopt "
        f"calibrate-stiffness ({key.upper()}, thesis Eq. {eq})\n"
        f"from {_count_tests(n_tests, result.n_distinct)} at {n_poses} poses. Replace the "
        "joint_stiffness_mnm_per_rad block of robot.yaml\n"
        f"with this one (keep the other set if you use it); a scenario selects it with "
        f"robot.stiffness: {key}.\n"
        f"standard errors [MNm/rad]: "
        f"{_fmt(se) if np.all(np.isfinite(se)) else 'not estimable (no residual left)'}\n"
        f"condition number {result.condition_number:.4g}; residual degrees of freedom "
        f"{result.dof_residual}")
    doc = {"joint_stiffness_mnm_per_rad": {key: [float(f"{v:.6g}") for v in k],
                                           "source": " ".join(source.split())}}
    body = yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=1000)
    return "".join(f"# {ln}\n" for ln in comments.splitlines()) + body


def _identify(args: argparse.Namespace) -> int:
    method = Method(args.method or Method.DPP)
    if args.out is not None:
        check_output_file(args.out, "--out", [".yaml", ".yml"], example="stiffness.yaml",
                          inputs=[args.tests_csv, Path(args.robot)])  # every robot file
    robot = load_robot(args.robot)
    tests, line_numbers = read_load_tests(args.tests_csv, robot)
    result = identify(robot, tests, method)
    names = [f"line {no}" for no in line_numbers]
    ones = np.ones(len(tests.q))
    n_poses = int(repeat_groups(tests.q, ones[:, None], ones > 0).max()) + 1  # within 0.01 deg
    measured = "translation" + (" + rotation" if tests.rotation is not None else "")
    print(f"robot: {robot.name}   {_count_tests(len(line_numbers), result.n_distinct)} at "
          f"{n_poses} pose{'s' * (n_poses != 1)}   "
          f"measured: {measured}")
    how = ("all six compliances at once (Eq. 3.19)" if method is Method.CP else
           "arm (joints 1-3) from the wrist-centre displacement, then the wrist (Eq. 3.20)")
    print(f"method: {method.value}, {how}")
    print(f"{'joint':>5} {'stiffness':>12} {'std. error':>12} {'rel.':>8}")
    print(f"{'':>5} {'[MNm/rad]':>12} {'[MNm/rad]':>12}")
    for j, (k, se) in enumerate(zip(result.stiffness, result.stiffness_se, strict=True)):
        print(f"{j + 1:>5} {k / _NM_PER_MNM:12.5g} {se / _NM_PER_MNM:12.2g} "
              f"{se / abs(k):8.2%}")
    print(f"condition number of the identification (columns scaled): "
          f"{result.condition_number:.4g}")
    _print_noise(result)
    print("residual per test (measured - predicted), |d| [mm] and |dtheta| [mrad]:")
    res_t = np.linalg.norm(result.residual[:, :3], axis=1) / MM
    res_r = np.linalg.norm(result.residual[:, 3:], axis=1) / _MRAD
    for name, rt, rr in zip(names, res_t, res_r, strict=True):
        rot = f"{rr:10.4f}" if np.isfinite(rr) else f"{'-':>10}"
        print(f"  {name:>10} {rt:10.4f} {rot}")
    for w in result.warnings:
        print(f"feedopt calibrate-stiffness: warning: {w.text(names)}", file=sys.stderr)
    if args.out is not None:
        bad = [w for w in result.warnings if w.kind is WarningKind.NON_PHYSICAL]
        if bad:
            raise InputError(f"{bad[0].text()}. Not writing {args.out}: robot.yaml takes "
                             "positive stiffnesses only")
        source = (f"feedopt calibrate-stiffness {Path(args.tests_csv).name} --method "
                  f"{method.value} (thesis 3.4, Eq. {'3.20' if method is Method.DPP else '3.19'})"
                  f", {_count_tests(len(line_numbers), result.n_distinct)}")
        text = stiffness_fragment(result, source, len(line_numbers), n_poses, robot.name)
        write_atomically(args.out, text)
        print(f"wrote {args.out}")
    return 0


# --------------------------------------------------------------------------- suggestion


def plan_csv(plan: LoadPlan, dof: int, rotations: bool, header_comment: str) -> str:
    """The test plan as a load-test CSV whose measurement cells are left empty."""
    cols = (joint_columns(dof) + FORCE_COLUMNS + MOMENT_COLUMNS + DISPLACEMENT_COLUMNS
            + (ROTATION_COLUMNS if rotations else ()))
    blanks = "," * (len(DISPLACEMENT_COLUMNS) + (3 if rotations else 0))
    out = [f"# {ln}" for ln in header_comment.splitlines()] + [",".join(cols)]
    for i, (q, loads) in enumerate(zip(plan.q, plan.wrench, strict=True)):
        x, y, z = plan.tcp_position[i] / MM
        out.append(f"# pose {i + 1}: TCP at x={x:.1f} y={y:.1f} z={z:.1f} mm, Jacobian "
                   f"condition number {plan.jacobian_condition[i]:.1f}")
        qs = ",".join(f"{v:.4f}" for v in np.rad2deg(q))
        for w in loads:
            out.append(f"{qs},{','.join(f'{v + 0.0:.3f}' for v in np.round(w, 3))}{blanks}")
    return "\n".join(out) + "\n"


def _suggest(args: argparse.Namespace) -> int:
    if args.out is not None:
        check_output_file(args.out, "--out", [".csv"], example="load_tests.csv",
                          inputs=[Path(args.robot)])  # every robot file
    robot = load_robot(args.robot)
    load = 1000.0 if args.load_n is None else args.load_n
    lever_mm = 200.0 if args.lever_mm is None else args.lever_mm
    seed = 0 if args.seed is None else args.seed
    rotations = not args.translations_only
    plan = suggest_poses(
        robot, args.suggest, PlanLoads(load=load, lever=lever_mm * MM, rotations=rotations),
        PoseCandidates(count=2000 if args.candidates is None else args.candidates, seed=seed))
    measured = "TCP displacement and rotation" if rotations else "TCP displacement"
    print(f"robot: {robot.name}   {len(plan.q)} poses chosen from {plan.candidates} random "
          f"non-singular candidates (seed {seed})")
    print(f"criterion: D-optimal, log det(A^T A) = {plan.log_det:.4g} (columns scaled by the "
          f"nominal compliances); condition number {plan.condition_number:.4g}")
    print(f"loads at each pose: {load:g} N along base +x, +y, -z, applied {lever_mm:g} mm from "
          f"the TCP along the tool x axis; measure the {measured}")
    qcols = joint_columns(robot.dof)
    print(f"{'pose':>4} " + " ".join(f"{c:>8}" for c in qcols)
          + f" {'x_mm':>8} {'y_mm':>8} {'z_mm':>8} {'cond':>6}")
    for i, q in enumerate(plan.q):
        print(f"{i + 1:>4} " + " ".join(f"{v:8.2f}" for v in np.rad2deg(q))
              + " " + " ".join(f"{v:8.1f}" for v in plan.tcp_position[i] / MM)
              + f" {plan.jacobian_condition[i]:6.1f}")
    if args.out is not None:
        comment = (
            f"Load tests planned by feedopt calibrate-stiffness --suggest {args.suggest} "
            f"--robot {' '.join(Path(args.robot).name.split())} --seed {seed}\n"
            f"(D-optimal, condition number {plan.condition_number:.4g}). Apply each row's "
            "wrench at the TCP,\nmeasure the "
            f"{measured} (base frame) and fill in the empty columns.\n"
            "Collisions were not checked: review every pose before moving the robot.")
        write_atomically(args.out, plan_csv(plan, robot.dof, rotations, comment))
        print(f"wrote {args.out}")
    else:
        print("(--out FILE.csv writes these tests as a CSV to fill in with the measurements)")
    return 0
