"""Every parser total (issue 33): an HP-GL number too long for a float or an int, a negative pen
or speed is one error naming the instruction (was OverflowError, or accepted); a photo whose name
is not UTF-8 is planned (was UnicodeEncodeError writing the SVG); a drawing a few mm wide is
compared with its photo (was skimage's ValueError in demo); a 65535 x 1 px strip is refused from
its size before anything is enlarged (was 1.9 GB)."""

import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from firmware_protocol import ProtocolError
from pencilbot.cli import main
from pencilbot.errors import PencilbotError
from pencilbot.export import svg_read
from pencilbot.firmware.hpgl import HPGL
from pencilbot.imaging.io import image_from_array
from pencilbot.imaging.pencil import sketch
from pencilbot.planning.fidelity import likeness

HUGE_INT = "9" * 30
HUGE_FLOAT = "9" * 400


@pytest.mark.parametrize(
    "program, instruction, words",
    [
        (f"IN;SP{HUGE_INT};PD100,100;", 2, "pen"),
        (f"IN;SP1;PA{HUGE_FLOAT},100;", 3, "beyond"),
        (f"IN;SP1;PD{HUGE_FLOAT},{HUGE_FLOAT};", 3, "beyond"),
        (f"IN;SP1;PU0,0;PR{HUGE_INT},0;", 4, "beyond"),
        ("IN;SP-3;PU0,0;PD100,100;", 2, "pen -3"),
        ("IN;SP1.5;PD1,1;", 2, "pen 1.5"),
        ("IN;VS-5;SP1;PD100,100;", 2, "speed -5"),
        (f"IN;VS{HUGE_FLOAT};SP1;PD100,100;", 2, "speed inf"),
    ],
)
def test_an_hpgl_number_out_of_range_is_one_error_naming_the_instruction(program, instruction, words):
    with pytest.raises(ProtocolError, match=f"instruction {instruction}.*{words}"):
        HPGL.program(program.encode())


@pytest.mark.parametrize("command", ["stat", "simulate", "draw"])
def test_the_commands_say_it_in_one_line(tmp_path, capsys, command):
    path = tmp_path / "big.hpgl"
    path.write_text(f"IN;SP1;PA{HUGE_FLOAT},100;PD100,100;SP0;\n")
    argv = {
        "stat": ["stat", str(path)],
        "simulate": ["simulate", str(path), "-o", str(tmp_path / "x.png"), "-q"],
        "draw": ["draw", str(path), "--port", "sim://", "-q"],
    }[command]
    assert main([*argv, "--profile", "hp7475a"]) == 2
    err = capsys.readouterr().err
    assert (
        err.startswith(f"pencilbot: error: {path}: instruction 3: coordinate inf,100")
        and err.count("\n") == 1
    )
    assert not (tmp_path / "x.png").exists()


@settings(max_examples=150, deadline=None)
@given(
    mnemonic=st.sampled_from(["SP", "VS", "PA", "PR", "PD", "PU"]),
    numbers=st.lists(
        st.one_of(
            st.integers(-(10**40), 10**40).map(str),
            st.floats(allow_nan=False, allow_infinity=False).map(repr),
            st.just(HUGE_FLOAT),
            st.just("-" + HUGE_FLOAT),
        ),
        min_size=1,
        max_size=4,
    ),
)
def test_any_number_after_any_instruction_reads_or_is_refused(mnemonic, numbers):
    text = f"IN;SP1;PU0,0;{mnemonic}{','.join(numbers)};PU;SP0;"
    try:
        program = HPGL.program(text.encode())
    except ProtocolError as exc:
        assert str(exc)  # the one error the commands report
        return
    assert (
        np.abs(program.xy).max(initial=0) <= 32767 and (program.pen >= 0).all() and (program.speed >= 0).all()
    )


def test_a_photo_named_in_bytes_that_are_not_utf8_is_planned(tmp_path, capsys):
    name = os.fsdecode(b"ph\xff\xfeoto.png")
    Image.fromarray(np.random.default_rng(1).integers(0, 255, (48, 64), dtype=np.uint8)).save(tmp_path / name)
    out = tmp_path / "plan.svg"
    assert main(["plan", str(tmp_path / name), "-o", str(out), "-q"]) == 0, capsys.readouterr().err
    out.read_bytes().decode("utf-8")  # valid UTF-8 throughout
    assert svg_read.read_svg(out).layers


def test_a_drawing_a_few_millimetres_wide_is_compared_with_its_photo():
    # demo --page 60x40 --pen-width 2.5: a drawing box of 3 x 2 mm at 10 px/mm.
    rng = np.random.default_rng(2)
    plotted = rng.random((20, 30)).astype(np.float32)
    result = likeness(plotted, plotted)
    assert result.ssim == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("shape", [(1, 65535), (65535, 1), (1, 8192)])
def test_a_strip_too_thin_to_enlarge_is_refused_before_anything_is_made(shape):
    image = image_from_array(np.full(shape, 0.5, np.float32), source="thin.png")
    with pytest.raises(PencilbotError, match=r"thin.png is \d+ x \d+ px, too thin to sketch"):
        sketch(image)


def test_a_strip_a_little_thin_is_still_sketched():
    image = image_from_array(np.random.default_rng(3).random((2, 600)).astype(np.float32), source="strip")
    assert sketch(image).result.shape == (2, 600)
