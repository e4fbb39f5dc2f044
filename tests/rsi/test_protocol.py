"""The RSI XML exchange against hand-written packets in the shape of the ROS-Industrial and
KUKA examples, read back with ElementTree independently."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from feedopt.errors import InputError
from feedopt.rsi.protocol import (
    PacketError,
    build_controller_packet,
    build_sensor_answer,
    check_sen_type,
    parse_address,
    parse_controller_packet,
    parse_sensor_answer,
)

# A controller packet as kuka_rsi_hw_interface's rsi_state.h reads it (RIst, RSol, AIPos,
# ASPos, Delay, IPOC), with whitespace and attribute order as a KRC might send them.
ROB = b"""<Rob TYPE="KUKA">
<RIst X="1750.1234" Y="-300.0000" Z="800.5000" A="-9.7276" B="0.0000" C="180.0000" />
<RSol X="1750.0000" Y="-300.0000" Z="800.0000" A="-9.7276" B="0.0000" C="180.0000" />
<AIPos A1="9.7276" A2="-64.7447" A3="107.0624" A4="0.0000" A5="47.6823" A6="0.0000" />
<ASPos A1="9.7276" A2="-64.7447" A3="107.0624" A4="0.0000" A5="47.6823" A6="0.0000" />
<Delay D="3" />
<IPOC>4208634724</IPOC>
</Rob>"""


def test_parse_controller_packet() -> None:
    p = parse_controller_packet(ROB)
    assert p.ipoc == 4208634724
    np.testing.assert_array_equal(p.rist, [1750.1234, -300.0, 800.5, -9.7276, 0.0, 180.0])
    np.testing.assert_array_equal(p.rsol[:3], [1750.0, -300.0, 800.0])
    np.testing.assert_array_equal(p.aipos, [9.7276, -64.7447, 107.0624, 0.0, 47.6823, 0.0])
    assert p.delay == 3


def test_minimal_packet_has_only_ipoc() -> None:
    p = parse_controller_packet(b"<Rob TYPE='KUKA'><IPOC>12</IPOC></Rob>")
    assert p.ipoc == 12 and p.rist is None and p.aipos is None and p.delay is None


def test_sensor_answer_echoes_ipoc_and_carries_rkorr() -> None:
    data = build_sensor_answer(4208634724, [0.1, -0.25, 1e-7, 0.5, 0.0, -180.0], stop=True,
                               sen_type="ImFree")
    root = ET.fromstring(data)  # read independently of parse_sensor_answer
    assert root.tag == "Sen" and root.get("Type") == "ImFree"
    assert root.findtext("IPOC") == "4208634724"
    rk = root.find("RKorr")
    got = [float(rk.get(a)) for a in "XYZABC"]
    np.testing.assert_allclose(got, [0.1, -0.25, 0.0, 0.5, 0.0, -180.0], atol=5e-7)
    assert root.findtext("Stop") == "1"
    back = parse_sensor_answer(data)
    assert back.ipoc == 4208634724 and back.stop is True and back.sen_type == "ImFree"
    assert parse_sensor_answer(build_sensor_answer(5, np.zeros(6))).stop is None


def test_controller_packet_round_trip() -> None:
    rist = np.array([1.5, 2.25, -3.0, 10.0, -20.0, 30.0])
    p = parse_controller_packet(build_controller_packet(8, rist=rist, rsol=rist + 1, delay=7))
    np.testing.assert_allclose(p.rist, rist, atol=5e-7)
    np.testing.assert_allclose(p.rsol, rist + 1, atol=5e-7)
    assert p.ipoc == 8 and p.delay == 7 and p.aipos is None


@pytest.mark.parametrize("data, fragment", [
    (b"hello", "not XML"),
    (b"<Sen Type='x'><IPOC>1</IPOC></Sen>", "root element <Sen>"),
    (b"<Rob TYPE='KUKA'></Rob>", "no <IPOC>"),
    (b"<Rob TYPE='KUKA'><IPOC>abc</IPOC></Rob>", "not an integer"),
    (b"<Rob TYPE='KUKA'><RIst X='1' Y='2' Z='3' A='4' B='5'/><IPOC>1</IPOC></Rob>",
     "no C attribute"),
    (b"<Rob TYPE='KUKA'><RIst X='nan' Y='2' Z='3' A='4' B='5' C='6'/><IPOC>1</IPOC></Rob>",
     "not finite"),
    (b"<!DOCTYPE x [<!ENTITY a 'b'>]><Rob><IPOC>1</IPOC></Rob>", "document type"),
    (b"<Rob>" + b" " * 5000 + b"</Rob>", "more than an RSI packet"),
])
def test_bad_packets(data, fragment) -> None:
    with pytest.raises(PacketError, match=fragment):
        parse_controller_packet(data)


def test_answer_without_rkorr_is_refused() -> None:
    with pytest.raises(PacketError, match="no <RKorr>"):
        parse_sensor_answer(b"<Sen Type='ImFree'><IPOC>1</IPOC></Sen>")


def test_parse_address() -> None:
    assert parse_address("127.0.0.1:49152", "--listen") == ("127.0.0.1", 49152)
    assert parse_address("[::1]:0", "--listen") == ("::1", 0)
    for bad, fragment in (("49152", "HOST:PORT"), ("host:port", "not a number"),
                          ("h:70000", "0-65535")):
        with pytest.raises(InputError, match=fragment):
            parse_address(bad, "--listen")


def test_sen_type_must_be_a_plain_name() -> None:
    assert check_sen_type("ImFree") == "ImFree"
    with pytest.raises(InputError, match="SENTYPE"):
        check_sen_type('a" b')


@pytest.mark.parametrize("space", ["cartesian", "axis"])
def test_the_exported_ethernet_configurations_read_back(tmp_path, space):
    from feedopt.export.rsi_program import ethernet_config_xml
    from feedopt.rsi.protocol import CorrectionSpace, read_ethernet_config

    p = tmp_path / "eth.xml"
    p.write_text(ethernet_config_xml(space=CorrectionSpace(space), sen_type="FeedOpt"))
    fmt = read_ethernet_config(p)
    assert fmt.space is CorrectionSpace(space) and fmt.sen_type == "FeedOpt"
    assert fmt.element == ("RKorr" if space == "cartesian" else "AK") and fmt.stop == "Stop"
