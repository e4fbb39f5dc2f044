"""The KUKA RSI Ethernet exchange: XML over UDP, one packet each way per controller cycle.

Every sensor cycle (4 ms with ``RSI_ON(..., #IPO_FAST)``, 12 ms with ``#IPO``) the
controller's ETHERNET object sends one ``<Rob TYPE="KUKA">`` document with what its Ethernet
configuration lists under ``<SEND>`` (``DEF_RIst``: actual Cartesian pose, ``DEF_RSol``:
setpoint pose, ``DEF_AIPos`` / ``DEF_ASPos``: actual / setpoint axis angles, ``DEF_Delay``:
the controller's count of late answers) and an ``<IPOC>`` timestamp. The sensor answers with
one ``<Sen Type="...">`` document holding the ``<RECEIVE>`` elements (here ``RKorr`` X Y Z A B C
and ``Stop``) and the same ``<IPOC>``. ``Type`` must equal the configuration's ``SENTYPE``;
an answer whose IPOC does not match the controller's current one is late and discarded.
Positions are mm, angles deg (KUKA A, B, C).

Followed, and tested against the same shapes:

- ROS-Industrial ``kuka_experimental``, ``kuka_rsi_hw_interface`` (commit e78bbd1):
  ``include/kuka_rsi_hw_interface/rsi_state.h`` (parses ``Rob`` / ``RIst`` / ``RSol`` /
  ``AIPos`` / ``ASPos`` / ``IPOC``), ``rsi_command.h`` (builds ``<Sen Type="ImFree">`` with
  the correction element and the echoed ``<IPOC>``), ``krl/KR_C4/ros_rsi_ethernet.xml`` and
  ``krl/KR_C4/README.md`` (IPOC echo, late answers, the ETHERNET ``Timeout``);
  ``kuka_rsi_simulator/scripts/kuka_rsi_simulator`` (the controller side).
- ros-industrial/kuka_experimental pull request #132: on a KRC4 (RSI 3.3) the IPOC advances
  by the cycle time in ms (4 with IPO_FAST, 12 with IPO); on RSI 2.3 (KRC2) by 1.
- erensezener/kuka-rsi3-communicator (RSI 3): ``ExternalData.xml``, ``server.py`` (the
  answer mirrors the received IPOC), ``kuka_files/RSI_EthernetConfig.xml``.
- kroshu/kuka-external-control-sdk (KUKA Hungaria): ``krc_setup/kss/Config/User/Common/
  SensorInterface/rsi_ethernet.xml``: a ``Stop`` BOOL element in ``<RECEIVE>`` (HOLDON 0)
  that ends ``RSI_MOVECORR()`` through the context's STOP object.
"""

from __future__ import annotations

import enum
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from feedopt.errors import InputError

#: Cartesian attributes of RIst / RSol / RKorr, in order (mm, mm, mm, deg, deg, deg).
CARTESIAN = ("X", "Y", "Z", "A", "B", "C")
#: Axis attributes of AIPos / ASPos (deg).
AXES = ("A1", "A2", "A3", "A4", "A5", "A6")
#: The sensor type of the ROS-Industrial and KUKA examples (``SENTYPE`` / ``Sen Type``).
DEFAULT_SEN_TYPE = "ImFree"
#: Largest datagram read; RSI packets are a few hundred bytes.
MAX_PACKET_BYTES = 4096
#: Decimals of the numbers in an answer (1 nm, 1e-6 deg).
DECIMALS = 6
_SEN_TYPE_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]{0,63}$")


class CorrectionSpace(enum.Enum):
    """What the answers correct: the TCP pose (``RKorr`` X..C, the context's POSCORR object)
    or the axes (``AK`` / ``AKorr`` A1..A6, its AXISCORR object: ROS-Industrial's
    kuka_rsi_hw_interface, kroshu's and FZI's drivers)."""

    CARTESIAN = "cartesian"
    AXIS = "axis"

    @property
    def names(self) -> tuple[str, ...]:
        """The correction element's attributes."""
        return CARTESIAN if self is CorrectionSpace.CARTESIAN else AXES


@dataclass(frozen=True)
class AnswerFormat:
    """The ``<Sen>`` document a controller's Ethernet configuration expects: ``Type``
    (its SENTYPE), the correction element (``RKorr``, ``AK``, ``AKorr``...) with its six
    attributes, and the Stop element (None: not configured, not sent)."""

    sen_type: str = "ImFree"
    element: str = "RKorr"
    names: tuple[str, ...] = CARTESIAN
    stop: str | None = "Stop"

    @property
    def space(self) -> CorrectionSpace:
        return CorrectionSpace.AXIS if self.names == AXES else CorrectionSpace.CARTESIAN

    @classmethod
    def default(cls, space: CorrectionSpace, sen_type: str = "ImFree") -> AnswerFormat:
        """feedopt's own configuration (:func:`feedopt.export.rsi_program.
        ethernet_config_xml`): ``RKorr`` or ``AK`` (ROS-Industrial's name), and ``Stop``."""
        element = "RKorr" if space is CorrectionSpace.CARTESIAN else "AK"
        return cls(sen_type, element, space.names, "Stop")


def read_ethernet_config(path: str | Path) -> AnswerFormat:
    """The :class:`AnswerFormat` of a KUKA RSI Ethernet configuration (``<ROOT><CONFIG>
    <SENTYPE>``, ``<RECEIVE><ELEMENTS><ELEMENT TAG="AK.A1" .../>``): the six ``NAME.X`` tags
    of one correction element, and a ``Stop`` tag if there is one. InputError naming the
    file and what it lacks."""
    from feedopt.textio import read_user_bytes

    path = Path(path)
    data = read_user_bytes(path, "Ethernet configuration")
    if b"<!DOCTYPE" in data or b"<!ENTITY" in data:
        raise InputError(f"{path}: document type declarations are not an RSI configuration")
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise InputError(f"{path}: not XML ({exc}); give the Ethernet configuration of the "
                         "context's ETHERNET object (e.g. feedopt_rsi_ethernet.xml)") from None
    sen = (root.findtext("CONFIG/SENTYPE") or "").strip()
    if not sen:
        raise InputError(f"{path}: no <CONFIG><SENTYPE>; the answers' Type must equal it")
    tags = [(el.get("TAG") or "").strip() for el in root.findall("RECEIVE/ELEMENTS/ELEMENT")]
    groups: dict[str, list[str]] = {}
    for tag in tags:
        element, dot, attribute = tag.partition(".")
        if dot:
            groups.setdefault(element, []).append(attribute)
    found = [(e, tuple(a)) for e, a in groups.items() if set(a) in (set(CARTESIAN), set(AXES))]
    if len(found) != 1:
        have = ", ".join(tags) or "none"
        raise InputError(
            f"{path}: its <RECEIVE> elements must hold one correction: six tags NAME.X .. "
            f"NAME.C (Cartesian, e.g. RKorr.X) or NAME.A1 .. NAME.A6 (axes, e.g. AK.A1); it "
            f"has {have}")
    element, names = found[0]
    names = CARTESIAN if set(names) == set(CARTESIAN) else AXES
    stop = next((t for t in tags if t.lower() == "stop"), None)
    return AnswerFormat(check_sen_type(sen), element, names, stop)


class PacketError(ValueError):
    """A datagram that is not the RSI document expected (the message says what is wrong)."""


@dataclass(frozen=True)
class ControllerPacket:
    """One ``<Rob>`` document: what the controller sent this cycle.

    ``rist`` / ``rsol``: (6,) X, Y, Z [mm], A, B, C [deg] or None when not configured;
    ``aipos`` / ``aspos``: (6,) axis angles [deg] or None; ``delay``: the controller's
    count of late answers (``DEF_Delay``) or None.
    """

    ipoc: int
    rist: np.ndarray | None = None
    rsol: np.ndarray | None = None
    aipos: np.ndarray | None = None
    aspos: np.ndarray | None = None
    delay: int | None = None


@dataclass(frozen=True)
class SensorAnswer:
    """One ``<Sen>`` document: ``rkorr`` (6,) X, Y, Z [mm], A, B, C [deg] (or, with
    ``element`` an axis correction, A1..A6 [deg]); ``stop`` True asks the context's STOP
    object to end ``RSI_MOVECORR()`` (None: no ``Stop`` element)."""

    ipoc: int
    rkorr: np.ndarray
    stop: bool | None = None
    sen_type: str = DEFAULT_SEN_TYPE
    element: str = "RKorr"


def check_sen_type(sen_type: str) -> str:
    """``sen_type`` if it can be the ``Type`` attribute (and ``SENTYPE``), else InputError."""
    if not _SEN_TYPE_RE.match(sen_type):
        raise InputError(f"--sen-type {sen_type!r}: use 1-64 letters, digits, '_', '.' or '-' "
                         f"starting with a letter (the controller's SENTYPE, e.g. "
                         f"{DEFAULT_SEN_TYPE})")
    return sen_type


def _parse(data: bytes, root_tag: str) -> ET.Element:
    if len(data) > MAX_PACKET_BYTES:
        raise PacketError(f"{len(data)} bytes, more than an RSI packet ({MAX_PACKET_BYTES})")
    if b"<!DOCTYPE" in data or b"<!ENTITY" in data:
        raise PacketError("document type declarations are not RSI")
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise PacketError(f"not XML ({exc})") from None
    if root.tag != root_tag:
        raise PacketError(f"root element <{root.tag}>, expected <{root_tag}>")
    return root


def _ipoc(root: ET.Element) -> int:
    el = root.find("IPOC")
    if el is None or el.text is None:
        raise PacketError("no <IPOC> timestamp")
    try:
        value = int(el.text.strip())
    except ValueError:
        raise PacketError(f"<IPOC> is {el.text.strip()!r}, not an integer") from None
    if value < 0:
        raise PacketError(f"<IPOC> is negative ({value})")
    return value


def _vector(root: ET.Element, tag: str, names: tuple[str, ...],
            finite: bool = True) -> np.ndarray | None:
    el = root.find(tag)
    if el is None:
        return None
    out = np.empty(len(names))
    for i, name in enumerate(names):
        text = el.get(name)
        if text is None:
            raise PacketError(f"<{tag}> has no {name} attribute")
        try:
            out[i] = float(text)
        except ValueError:
            raise PacketError(f"<{tag}> {name}={text!r} is not a number") from None
        if finite and not math.isfinite(out[i]):
            raise PacketError(f"<{tag}> {name}={text!r} is not finite")
    return out


def parse_controller_packet(data: bytes) -> ControllerPacket:
    """Read a ``<Rob TYPE="KUKA">`` datagram (PacketError when it is not one)."""
    root = _parse(data, "Rob")
    delay = None
    el = root.find("Delay")
    if el is not None:
        try:
            delay = int(el.get("D", ""))
        except ValueError:
            raise PacketError(f"<Delay D={el.get('D')!r}> is not an integer") from None
    return ControllerPacket(ipoc=_ipoc(root), rist=_vector(root, "RIst", CARTESIAN),
                            rsol=_vector(root, "RSol", CARTESIAN),
                            aipos=_vector(root, "AIPos", AXES),
                            aspos=_vector(root, "ASPos", AXES), delay=delay)


def parse_sensor_answer(data: bytes, finite: bool = True) -> SensorAnswer:
    """Read a ``<Sen Type="...">`` datagram (PacketError when it is not one, or lacks RKorr;
    with ``finite`` also when an RKorr value is not finite: the simulated controller reads
    them as a KRC would, as numbers, and refuses them itself)."""
    root = _parse(data, "Sen")
    element, rkorr = "RKorr", _vector(root, "RKorr", CARTESIAN, finite)
    for axis_element in ("AK", "AKorr"):
        if rkorr is None:
            element, rkorr = axis_element, _vector(root, axis_element, AXES, finite)
    if rkorr is None:
        raise PacketError("no <RKorr> (or <AK> / <AKorr>) correction")
    stop = None
    el = root.find("Stop")
    if el is not None:
        text = (el.text or "").strip()
        if text not in ("0", "1"):
            raise PacketError(f"<Stop> is {text!r}, expected 0 or 1")
        stop = text == "1"
    return SensorAnswer(ipoc=_ipoc(root), rkorr=rkorr, stop=stop,
                        sen_type=root.get("Type", ""), element=element)


def _attributes(names: tuple[str, ...], values) -> str:
    return " ".join(f'{n}="{float(v):.{DECIMALS}f}"' for n, v in zip(names, values, strict=True))


def build_sensor_answer(ipoc: int, rkorr, stop: bool | None = None,
                        sen_type: str = DEFAULT_SEN_TYPE,
                        fmt: AnswerFormat | None = None) -> bytes:
    """The ``<Sen>`` answer to the packet with timestamp ``ipoc``: the correction ``rkorr``
    (6,) mm / deg in ``fmt``'s element (default ``RKorr`` X..C; ``AK`` A1..A6 [deg] in axis
    mode, ``rsi_command.h``), an optional Stop element (sent only where ``fmt`` has one) and
    the echoed ``<IPOC>`` (``rsi_command.h``, ``server.py``)."""
    fmt = AnswerFormat(sen_type=sen_type) if fmt is None else fmt
    stop_el = ("" if stop is None or fmt.stop is None
               else f"<{fmt.stop}>{int(bool(stop))}</{fmt.stop}>")
    return (f'<Sen Type="{fmt.sen_type}"><EStr>feedopt</EStr>'
            f"<{fmt.element} {_attributes(fmt.names, rkorr)} />{stop_el}"
            f"<IPOC>{int(ipoc)}</IPOC></Sen>").encode("ascii")


def build_controller_packet(ipoc: int, rist=None, rsol=None, aipos=None, aspos=None,
                            delay: int | None = None) -> bytes:
    """A ``<Rob TYPE="KUKA">`` packet as the controller sends it (for the simulator)."""
    parts = ['<Rob TYPE="KUKA">']
    for tag, names, values in (("RIst", CARTESIAN, rist), ("RSol", CARTESIAN, rsol),
                               ("AIPos", AXES, aipos), ("ASPos", AXES, aspos)):
        if values is not None:
            parts.append(f"<{tag} {_attributes(names, values)} />")
    if delay is not None:
        parts.append(f'<Delay D="{int(delay)}" />')
    parts.append(f"<IPOC>{int(ipoc)}</IPOC></Rob>")
    return "".join(parts).encode("ascii")


def parse_address(text: str, option: str) -> tuple[str, int]:
    """``HOST:PORT`` -> (host, port); InputError naming ``option`` otherwise (port 0-65535;
    0 asks the system for a free port where the command binds)."""
    host, sep, port_text = str(text).rpartition(":")
    example = f"{option} 127.0.0.1:49152"
    if not sep or not host:
        raise InputError(f"{option} {text!r}: give HOST:PORT (e.g. {example})")
    try:
        port = int(port_text)
    except ValueError:
        raise InputError(f"{option} {text!r}: the port {port_text!r} is not a number (e.g. "
                         f"{example})") from None
    if not 0 <= port <= 65535:
        raise InputError(f"{option} {text!r}: the port must be 0-65535 (e.g. {example})")
    return host.strip("[]"), port
