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

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

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
    """One ``<Sen>`` document: ``rkorr`` (6,) X, Y, Z [mm], A, B, C [deg]; ``stop`` True asks
    the context's STOP object to end ``RSI_MOVECORR()`` (None: no ``Stop`` element)."""

    ipoc: int
    rkorr: np.ndarray
    stop: bool | None = None
    sen_type: str = DEFAULT_SEN_TYPE


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
    rkorr = _vector(root, "RKorr", CARTESIAN, finite)
    if rkorr is None:
        raise PacketError("no <RKorr> correction")
    stop = None
    el = root.find("Stop")
    if el is not None:
        text = (el.text or "").strip()
        if text not in ("0", "1"):
            raise PacketError(f"<Stop> is {text!r}, expected 0 or 1")
        stop = text == "1"
    return SensorAnswer(ipoc=_ipoc(root), rkorr=rkorr, stop=stop,
                        sen_type=root.get("Type", ""))


def _attributes(names: tuple[str, ...], values) -> str:
    return " ".join(f'{n}="{float(v):.{DECIMALS}f}"' for n, v in zip(names, values, strict=True))


def build_sensor_answer(ipoc: int, rkorr, stop: bool | None = None,
                        sen_type: str = DEFAULT_SEN_TYPE) -> bytes:
    """The ``<Sen>`` answer to the packet with timestamp ``ipoc``: ``rkorr`` (6,) mm / deg,
    an optional ``<Stop>`` and the echoed ``<IPOC>`` (``rsi_command.h``, ``server.py``)."""
    stop_el = "" if stop is None else f"<Stop>{int(bool(stop))}</Stop>"
    return (f'<Sen Type="{sen_type}"><EStr>feedopt</EStr>'
            f"<RKorr {_attributes(CARTESIAN, rkorr)} />{stop_el}"
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
