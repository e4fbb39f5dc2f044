"""A scenario with every file it reads, shipped to the sweep's workers.

Workers of a remote Dask cluster do not see the files of the machine that starts the sweep,
so the sweep sends them along: the scenario's YAML data, its robot directory (robot.yaml and
the URDF it names), tool, material, waypoint/G-code file and stock mesh, as bytes. Each worker
process writes them once into a temporary folder of its own (removed when it exits) and
plans every point from there; a point that changes robot.yaml (``robot_yaml.`` axes) gets a
robot folder of its own beside it. The digest of the bundle identifies the inputs of a sweep,
so a resumed sweep can check that they did not change.
"""

from __future__ import annotations

import atexit
import copy
import hashlib
import json
import os
import re
import shutil
import tempfile
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

import yaml
from pydantic import ValidationError

from feedopt.errors import InputError
from feedopt.scenario import (
    PROGRAM_GENERATORS,
    Scenario,
    format_validation_error,
    load_scenario,
    resolve,
)
from feedopt.sweep.grid import Axis, Number, apply_point
from feedopt.textio import read_user_bytes
from feedopt.yamlio import read_yaml_mapping

#: Largest total size of the files a sweep ships to each worker.
MAX_BUNDLE_BYTES = 256 * 2**20
ROBOT_DIR = "robot"


@dataclass(frozen=True)
class Bundle:
    """A scenario and the files it reads, independent of the machine that reads it.

    Attributes
    ----------
    source : str
        The scenario file as the user named it (for messages).
    raw : dict
        The scenario's YAML data with every file field pointing into the bundle.
    robot_doc : dict
        The robot's robot.yaml data.
    files : tuple of (str, bytes)
        Bundle-relative path and content of every file.
    urdf : str
        Bundle-relative path of the URDF.
    origins : tuple of (str, str)
        Bundle-relative path and the user's path of the robot directory and of each file
        (messages name the user's files, not the workers' copies).
    digest : str
        SHA-256 of all of the above but ``source``.
    """

    source: str
    raw: dict
    robot_doc: dict
    files: tuple[tuple[str, bytes], ...]
    urdf: str
    origins: tuple[tuple[str, str], ...]
    digest: str

    def readable(self, text: str, root: Path) -> str:
        """``text`` with the paths of the copies under ``root`` replaced by the user's."""
        copy_dir = str(root / ROBOT_DIR)
        text = re.sub(re.escape(copy_dir) + r"-[0-9a-f]+", lambda _m: copy_dir, text)
        for inner, original in sorted(self.origins, key=lambda o: -len(o[0])):
            text = text.replace(str(root / inner), original)
        return text


def _read(path: Path, what: str) -> bytes:
    """The bytes of one input file, through the capped reader (no FIFO, no device, bounded)."""
    return read_user_bytes(path, what)


def build_bundle(scenario_path: str | Path) -> tuple[Bundle, Scenario]:
    """Read ``scenario_path`` and every file it names; the bundle and the validated scenario.

    Raises
    ------
    InputError
        What ``feedopt validate`` refuses (schema, files, robot, tool, material, path), a URDF
        outside the robot directory, or more than :data:`MAX_BUNDLE_BYTES` of files.
    """
    from feedopt.runner import validate_scenario

    scenario_path = Path(scenario_path)
    scenario, base = load_scenario(scenario_path)
    validate_scenario(scenario_path)
    raw = copy.deepcopy(read_yaml_mapping(scenario_path, "scenario file"))
    robot_dir = resolve(base, scenario.robot.directory, "robot directory")
    robot_doc = read_yaml_mapping(robot_dir / "robot.yaml", "robot file")
    urdf = PurePosixPath(str(robot_doc["urdf"]))
    if urdf.is_absolute() or ".." in urdf.parts:
        raise InputError(f"{robot_dir / 'robot.yaml'}: urdf '{urdf}' is outside the robot "
                         "directory; a sweep ships the robot directory to its workers: put the "
                         "URDF in it")
    files = [(f"{ROBOT_DIR}/robot.yaml", _read(robot_dir / "robot.yaml", "robot file")),
             (f"{ROBOT_DIR}/{urdf}", _read(robot_dir / str(urdf), "URDF"))]
    raw["robot"]["directory"] = ROBOT_DIR
    origins = [(ROBOT_DIR, str(robot_dir))]
    named = [(("tool",), scenario.tool, "tool file"),
             (("material",), scenario.material, "material file")]
    if scenario.path.generator in ("csv", *PROGRAM_GENERATORS):
        named.append((("path", "file"), scenario.path.file, "path.file"))
    if scenario.stock is not None and scenario.stock.mesh is not None:
        named.append((("stock", "mesh"), scenario.stock.mesh, "stock.mesh"))
    for keys, rel, what in named:
        path = resolve(base, rel, what)
        inner = f"{'_'.join(keys)}/{path.name}"
        files.append((inner, _read(path, what)))
        origins.append((inner, str(path)))
        node = raw
        for k in keys[:-1]:
            node = node[k]
        node[keys[-1]] = inner
    total = sum(len(data) for _, data in files)
    if total > MAX_BUNDLE_BYTES:
        raise InputError(f"{scenario_path}: its files add up to {total / 2**20:.0f} MiB; a sweep "
                         f"sends them to every worker and takes at most "
                         f"{MAX_BUNDLE_BYTES / 2**20:.0f} MiB (a coarser stock mesh?)")
    h = hashlib.sha256(json.dumps([raw, robot_doc], sort_keys=True, default=repr).encode())
    for name, data in files:
        h.update(name.encode() + b"\0" + hashlib.sha256(data).digest())
    return Bundle(source=str(scenario_path), raw=raw, robot_doc=robot_doc, files=tuple(files),
                  urdf=f"{ROBOT_DIR}/{urdf}", origins=tuple(origins),
                  digest=h.hexdigest()), scenario


# --- on the worker ------------------------------------------------------------------------

_ROOTS: dict[str, Path] = {}
_LOCK = threading.Lock()


def _write(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)


_PREFIX = "feedopt-sweep-"


def _remove_stale_copies() -> None:
    """Remove the copies of worker processes that were killed before they could (their
    folder names carry their pid)."""
    from feedopt.outdir import _pid_alive

    for folder in Path(tempfile.gettempdir()).glob(f"{_PREFIX}*-*"):
        pid = folder.name.removeprefix(_PREFIX).split("-")[0]
        if pid.isdigit() and int(pid) != os.getpid() and not _pid_alive(int(pid)):
            shutil.rmtree(folder, ignore_errors=True)


def materialise(bundle: Bundle) -> Path:
    """The folder holding ``bundle``'s files in this process (written once, removed at exit,
    or by a later sweep if this process is killed)."""
    with _LOCK:
        root = _ROOTS.get(bundle.digest)
        if root is not None and root.is_dir():
            return root
        if not _ROOTS:
            _remove_stale_copies()
        root = Path(tempfile.mkdtemp(prefix=f"{_PREFIX}{os.getpid()}-"))
        atexit.register(shutil.rmtree, root, True)
        for name, data in bundle.files:
            _write(root / name, data)
        _ROOTS[bundle.digest] = root
        return root


def _robot_dir(bundle: Bundle, root: Path, robot_doc: dict | None) -> Path:
    """The robot folder of a point: the bundle's, or one with its own robot.yaml."""
    if robot_doc is None:
        return root / ROBOT_DIR
    text = yaml.safe_dump(robot_doc, sort_keys=False, allow_unicode=True)
    folder = root / f"{ROBOT_DIR}-{hashlib.sha256(text.encode()).hexdigest()[:16]}"
    with _LOCK:
        if not folder.is_dir():
            tmp = Path(tempfile.mkdtemp(dir=root))
            (tmp / "robot.yaml").write_text(text, encoding="utf-8")
            urdf = bundle.urdf.removeprefix(f"{ROBOT_DIR}/")
            _write(tmp / urdf, (root / bundle.urdf).read_bytes())
            tmp.rename(folder)
    return folder


def describe(axes: Sequence[Axis], values: Sequence[Number]) -> str:
    """``a=1, b=2`` for messages."""
    return ", ".join(f"{a.name}={v}" for a, v in zip(axes, values, strict=True))


def scenario_at(bundle: Bundle, axes: Sequence[Axis], values: Sequence[Number],
                source: str | None = None) -> tuple[Scenario, Path]:
    """The validated scenario of one grid point and the folder its files resolve against.

    Raises
    ------
    InputError
        The point's scenario is invalid (named by ``source``, default: the scenario file and
        the point's values).
    """
    root = materialise(bundle)
    raw, robot_doc = apply_point(bundle.raw, bundle.robot_doc, axes, values)
    raw["robot"]["directory"] = str(_robot_dir(bundle, root, robot_doc))
    try:
        scenario = Scenario.model_validate(raw)
    except ValidationError as exc:
        where = source or f"{bundle.source} at {describe(axes, values)}"
        raise InputError(format_validation_error(exc, where)) from None
    return scenario, root


def check_axes(bundle: Bundle, axes: Sequence[Axis]) -> None:
    """Validate every value of every axis on its own, as the user's input, before any work.

    A scenario value is validated by the schema; a robot.yaml value by loading the robot.
    A value that is only invalid together with another axis's is a row of the table.
    """
    from feedopt.robot.model import load_robot

    for axis in axes:
        for value in axis.values:
            where = f"--grid {axis.name}={value}"
            scenario, base = scenario_at(bundle, [axis], [value], source=where)
            if axis.in_robot:
                try:
                    load_robot(resolve(base, scenario.robot.directory, "robot directory"))
                except InputError as exc:
                    raise InputError(f"{where}: {bundle.readable(str(exc), base)}") from None
