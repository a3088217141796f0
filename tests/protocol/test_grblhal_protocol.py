"""grblHAL's protocol: GRBL's grammar, its own banner (and GRBL's in compatibility mode), longer lines."""

import pytest

from firmware_protocol import ProtocolError, grbl, grblhal


def test_both_banners_are_a_reset_and_the_rest_is_grbl_s_grammar():
    assert grblhal.parse_line(grblhal.BANNER) == grbl.Welcome("1.1f")
    assert grblhal.parse_line("Grbl 1.1f ['$' for help]") == grbl.Welcome("1.1f")  # compatibility mode
    assert grbl.parse_line(grblhal.BANNER) == grbl.Unknown(grblhal.BANNER)  # not GRBL's banner
    assert grblhal.parse_line("<Idle|MPos:1.000,2.000,0.000|Bf:35,1024|FS:0,0>") == grbl.Status(
        "Idle", mpos=(1.0, 2.0, 0.0), buffer=(35, 1024), feed=0.0, spindle=0.0
    )
    assert grblhal.parse_line("error:20") == grbl.Error(20)


def test_lines_may_be_256_characters_long():
    longer = "G1X" + "1" * 80  # 83 characters: too long for GRBL 1.1
    with pytest.raises(ProtocolError, match="GRBL accepts at most 79"):
        grbl.encode_line(longer)
    assert grblhal.encode_line(longer) == longer.encode() + b"\n"
    assert grblhal.encode_line("G1X" + "1" * 253) == b"G1X" + b"1" * 253 + b"\n"
    with pytest.raises(ProtocolError, match="257 characters long .*grblHAL accepts at most 256"):
        grblhal.encode_line("G1X" + "1" * 254)
    assert grblhal.build_report("", "VL")[1] == "[OPT:VNMSL,35,1024,3,0]"
