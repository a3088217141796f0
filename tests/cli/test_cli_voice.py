"""Every command speaks the same way: the same option has the same default and spelling
everywhere, old spellings still work for a release with a note, a resumed job's options can be
overridden."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pencilbot.cli import build_parser, main
from pencilbot.commands.draw import connection_options


def test_a_given_on_error_overrides_the_resumed_job_s_either_way():
    parser = build_parser()
    journal = {"timeout": 3.0, "send_and_wait": True, "on_error": "continue"}
    given = parser.parse_args(["draw", "--resume", "job", "--on-error", "stop"])
    assert connection_options(given, journal) == (3.0, True, "stop")
    kept = parser.parse_args(["draw", "--resume", "job"])
    assert connection_options(kept, journal) == (3.0, True, "continue")
    assert connection_options(kept, {})[2] == "stop"


def test_the_virtual_plotter_s_speed_has_one_default():
    parser = build_parser()
    simulate = parser.parse_args(["simulate", "x.gcode", "-o", "x.png"])
    serve = parser.parse_args(["sim-serve"])
    assert simulate.realtime == serve.realtime == 0.0 and simulate.dpi == serve.dpi


def test_draw_takes_a_profile_as_the_other_commands_do(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["draw", "--list-profiles"])
    assert stop.value.code == 0
    assert "grbl-servo-a4" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["draw", "--help"])
    assert "--profile NAME|FILE.toml" in capsys.readouterr().out


def test_demo_takes_a_positional_photo_and_o_and_its_old_spellings_with_a_note(capsys):
    parser = build_parser()
    new = parser.parse_args(["demo", "p.png", "-o", "out"])
    old = parser.parse_args(["demo", "--input", "p.png", "--out", "out"])
    assert (new.input, new.output) == (old.old_input, old.output) == ("p.png", "out")
    err = capsys.readouterr().err
    assert "--input is deprecated" in err and "--out is deprecated" in err and "-o/--output" in err


# --- one voice: exit codes, missing files, the simulator's speed, the fault kinds ---------------

README = (Path(__file__).resolve().parents[2] / "README.md").read_text(encoding="utf-8")


def test_the_exit_codes_are_the_ones_the_readme_lists():
    from pencilbot.errors import PencilbotError, PlotError, RefusedError

    listed = dict(re.findall(r"^\| (\d+) \| (.+) \|$", README, re.M))
    assert set(listed) == {"0", "1", "2", "3", "130"}
    assert "usage mistake or bad input" in listed["2"] and "plotter stopped" in listed["3"]
    assert (PencilbotError.exit_code, PlotError.exit_code, RefusedError.exit_code) == (2, 3, 2)
    assert issubclass(RefusedError, PlotError)  # code catching every refusal to plot still does


def _gcode(tmp_path, lines=("G21", "G90", "M3 S30", "G0 X10 Y10", "M3 S90", "G1 X40 Y10 F3000", "M3 S30")):
    path = tmp_path / "job.gcode"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize(
    "argv",
    [
        ["draw", "{job}"],  # no port
        ["draw", "{tmp}/missing.gcode", "--port", "sim://"],
        ["draw", "{tmp}/cat.jpg", "--port", "sim://"],  # a picture, not G-code
        ["draw", "{job}", "--port", "sim://", "--start-line", "99"],
        ["draw", "--resume", "{tmp}/nothing.gcode", "--port", "sim://"],  # no journal
        ["draw", "{job}", "--port", "sim://", "--profile", "hp7475a"],  # G-code to an HP-GL plotter
    ],
)
def test_draw_usage_mistakes_exit_2_and_send_nothing(argv, tmp_path, capsys):
    job = _gcode(tmp_path)
    code = main([a.format(job=job, tmp=tmp_path) for a in argv])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("pencilbot: error: ") and err.count("\n") == 1 and "Traceback" not in err


def test_a_plotter_that_stops_exits_3_with_the_resume_command(tmp_path, capsys):
    job = _gcode(tmp_path)
    code = main(
        ["draw", str(job), "--port", "sim://voice-stop?faults=error@6", "--profile", "grbl-servo-a4", "-q"]
    )
    err = capsys.readouterr().err
    assert code == 3 and "Resume with: pencilbot draw --resume" in err, err


def test_ports_names_a_port_that_cannot_be_opened_and_exits_2(tmp_path, capsys):
    missing = str(tmp_path / "ttyNOPE")
    for argv in (["ports", missing], ["ports", missing, "--no-probe"], ["ports", missing, "--json"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert (
            err.startswith(f"pencilbot: error: cannot open the port named: {missing} (")
            and err.count("\n") == 1
        )
    assert main(["ports", "sim://", "--no-probe", "-q"]) == 0


@pytest.mark.parametrize(
    "argv",
    [
        ["sketch", "{missing}.png", "-o", "{tmp}/out.png"],
        ["plan", "{missing}.png", "-o", "{tmp}/out.svg"],
        ["export", "{missing}.png", "-o", "{tmp}/out.gcode"],
        ["export", "{missing}.svg", "-o", "{tmp}/out.gcode"],
        ["stat", "{missing}.svg"],
        ["optimize", "{missing}.svg", "-o", "{tmp}/out.svg"],
        ["simulate", "{missing}.gcode", "-o", "{tmp}/out.png"],
        ["draw", "{missing}.gcode", "--port", "sim://"],
        ["studio", "{missing}.png", "--no-browser"],
    ],
)
def test_a_missing_input_is_said_one_way_by_every_command(argv, tmp_path, capsys):
    missing = tmp_path / "missing"
    code = main([a.format(missing=missing, tmp=tmp_path) for a in argv])
    err = capsys.readouterr().err
    assert code == 2, err
    assert re.fullmatch(
        rf"pencilbot: error: (.*: )?{re.escape(str(missing))}\.\w+: no such file; give .+\n", err
    ), err


def command_help(command: str) -> str:
    """``pencilbot COMMAND --help``, as argparse prints it."""
    parser = build_parser(only=command.replace("-", "_"))
    return parser._subparsers._group_actions[0].choices[command].format_help()


def test_the_studio_takes_the_simulator_s_speed_as_realtime_and_its_old_spelling_with_a_note(capsys):
    parser = build_parser()
    assert parser.parse_args(["studio"]).realtime == 1.0  # watching a plot: as fast as the machine
    assert parser.parse_args(["studio", "--realtime", "4"]).realtime == 4.0
    assert parser.parse_args(["studio", "--sim-speed", "3"]).realtime == 3.0
    assert "--sim-speed is deprecated" in capsys.readouterr().err
    for command in ("simulate", "sim-serve", "studio"):
        assert "--realtime R" in command_help(command)


def test_sim_serve_and_the_docs_list_every_fault_kind():
    from sim.faults import FAULT_KINDS

    helped = " ".join(command_help("sim-serve").split())
    notes = (Path(__file__).resolve().parents[2] / "docs" / "firmware.md").read_text(encoding="utf-8")
    for kind in FAULT_KINDS:
        assert kind in helped and f"`{kind}@" in notes, kind


def test_every_command_that_writes_a_file_takes_o_and_has_a_default():
    for command in ("sketch", "plan", "optimize", "stat", "export", "simulate", "sim-serve", "demo"):
        parser = build_parser(only=command.replace("-", "_"))._subparsers._group_actions[0].choices[command]
        output = [a for a in parser._actions if "--output" in a.option_strings]
        if command == "stat":
            assert not output  # it prints
            continue
        assert output and output[0].option_strings == ["-o", "--output"] and not output[0].required, command


def test_without_o_the_output_goes_beside_the_input_named_for_what_it_is(tmp_path, capsys):
    from skimage import data
    from skimage import io as skio

    photo = tmp_path / "cat.png"
    skio.imsave(photo, data.camera()[::16, ::16])
    job = _gcode(tmp_path)
    for argv, written in (
        (["sketch", str(photo), "-q"], "cat-sketch.png"),
        (["plan", str(photo), "--page", "60x60", "-q"], "cat.svg"),
        (["optimize", str(tmp_path / "cat.svg"), "-q"], "cat-optimized.svg"),
        (["simulate", str(job), "--dpi", "20", "-q"], "job-plot.png"),
    ):
        assert main(argv) == 0, capsys.readouterr().err
        assert (tmp_path / written).is_file(), argv
    # The default never replaces an input: a photo named like a sketch gets its own name.
    assert main(["sketch", str(tmp_path / "cat-sketch.png"), "-q"]) == 0
    assert (tmp_path / "cat-sketch-sketch.png").is_file()
