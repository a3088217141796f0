"""What a user configures: their own folder of profiles and styles (found by name before the
shipped ones), the default profile and style, the listings, and shell completion."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pencilbot import configs_io
from pencilbot.cli import main
from pencilbot.configs_io import config_folder, user_folder
from pencilbot.export.svg import write_svg
from pencilbot.export.svg_read import read_svg
from pencilbot.machine.profile import default_profile, load_profile
from pencilbot.planning.plan import Layer, Page, Plan
from pencilbot.planning.style import default_style, load_style


@pytest.fixture
def mine(monkeypatch, tmp_path) -> Path:
    folder = tmp_path / "mine"
    monkeypatch.setenv("PENCILBOT_CONFIG_DIR", str(folder))
    (folder / "plotters").mkdir(parents=True)
    (folder / "styles").mkdir()
    return folder


def listing(argv):
    """Run a listing option: like --help and --version, it prints and exits at once."""
    with pytest.raises(SystemExit) as done:
        main(argv)
    assert done.value.code == 0


def shipped(name: str) -> str:
    return (config_folder("plotters") / f"{name}.toml").read_text()


@pytest.fixture
def plan_svg(tmp_path) -> Path:
    path = tmp_path / "plan.svg"
    write_svg(
        Plan(Page(148, 210, 10, "A5"), [Layer("edges", [np.array([[20.0, 20.0], [120.0, 190.0]])])]), path
    )
    return path


@pytest.mark.parametrize(
    ("platform", "env", "want"),
    [
        ("linux", {"XDG_CONFIG_HOME": "/x/cfg"}, "/x/cfg/pencilbot"),
        ("linux", {}, "~/.config/pencilbot"),
        ("darwin", {}, "~/Library/Application Support/pencilbot"),
        ("win32", {"APPDATA": "/x/Roaming"}, "/x/Roaming/pencilbot"),
        ("linux", {"PENCILBOT_CONFIG_DIR": "/x/mine", "XDG_CONFIG_HOME": "/x/cfg"}, "/x/mine"),
    ],
)
def test_the_user_folder_follows_the_platform(monkeypatch, platform, env, want):
    for name in ("PENCILBOT_CONFIG_DIR", "XDG_CONFIG_HOME", "APPDATA"):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    monkeypatch.setattr(sys, "platform", platform)
    assert user_folder() == Path(want).expanduser()


def test_a_users_profile_is_found_by_name_before_the_shipped_one(mine, plan_svg, capsys):
    (mine / "plotters" / "grbl-servo-a4.toml").write_text(
        shipped("grbl-servo-a4").replace("draw_feed = 3000.0", "draw_feed = 1500.0")
    )
    (mine / "plotters" / "slow.toml").write_text(
        shipped("grbl-servo-a4").replace('name = "grbl-servo-a4"\n', "")
    )
    assert load_profile("grbl-servo-a4").motion.draw_feed == 1500.0
    assert load_profile("slow").name == "slow"
    listing(["export", "--list-profiles"])
    listed = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()}
    assert set(listed) == {
        "grbl-servo-a4",
        "grbl-z-a3",
        "grblhal-servo-a3",
        "marlin-servo-a4",
        "hp7475a",
        "hp7475a-a3",
        "axidraw-v3",
        "axidraw-a3",
        "nextdraw-8511",
        "idraw-a4",
        "slow",
    }
    assert f"(yours: {mine / 'plotters' / 'slow.toml'})" in listed["slow"]
    assert "(yours:" in listed["grbl-servo-a4"] and "(yours:" not in listed["grbl-z-a3"]
    assert main(["stat", str(plan_svg), "--profile", "slow", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["profile"] == "slow"


def test_an_unknown_name_says_where_a_users_file_would_go(mine, plan_svg, capsys):
    assert main(["stat", str(plan_svg), "--profile", "axidraw"]) == 2
    err = capsys.readouterr().err
    assert "no plotter profile named 'axidraw'" in err and f"put axidraw.toml in {mine / 'plotters'}" in err


def test_a_users_style_by_name_and_the_listing(mine, tmp_path, capsys):
    (mine / "styles" / "bold.toml").write_text('pen_width = 1.2\nhatch = false\npage = "A5"\n')
    assert load_style("bold").pen_width == 1.2
    listing(["plan", "--list-styles"])  # no photo or -o needed to list
    listed = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()}
    assert list(listed) == ["bold", "default", "outline", "sketchy"]
    assert "A5 auto, 1.2 mm pen, outline only (yours:" in listed["bold"]
    assert "A4 auto, 0.5 mm pen, hatching" in listed["default"]


def test_the_default_profile_comes_from_the_environment_then_the_settings(
    mine, plan_svg, monkeypatch, capsys
):
    def profile_used():
        assert main(["stat", str(plan_svg), "--json"]) == 0
        return json.loads(capsys.readouterr().out)["profile"]

    assert default_profile() == "grbl-servo-a4" == profile_used()
    (mine / "config.toml").write_text('profile = "marlin-servo-a4"\n')
    assert profile_used() == "marlin-servo-a4"
    monkeypatch.setenv("PENCILBOT_PROFILE", "grbl-z-a3")
    assert profile_used() == "grbl-z-a3"  # the environment wins
    monkeypatch.delenv("PENCILBOT_PROFILE")
    (mine / "own.toml").write_text(shipped("grbl-z-a3").replace('name = "grbl-z-a3"', 'name = "in-folder"'))
    (mine / "config.toml").write_text('profile = "own.toml"  # relative to the folder\n')
    assert profile_used() == str(mine / "own.toml") and load_profile(default_profile()).name == "in-folder"


def test_the_default_style_comes_from_the_settings(mine, tmp_path, capsys):
    from skimage import data
    from skimage import io as skio

    photo = tmp_path / "camera.png"
    skio.imsave(photo, data.camera()[::8, ::8])
    (mine / "config.toml").write_text('style = "outline"\n')
    assert default_style() == "outline"
    assert main(["plan", str(photo), "-o", str(tmp_path / "p.svg"), "-q"]) == 0
    plan = read_svg(tmp_path / "p.svg")
    assert [layer.name for layer in plan.layers] == ["edges"] and plan.meta["style"] == "outline"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('profil = "x"\n', "unknown key 'profil'; the keys are: profile, style"),
        ("profile = 3\n", "profile = 3 is invalid"),
        ("profile = \n", "not valid TOML"),
    ],
)
def test_a_bad_settings_file_is_one_plain_message(mine, plan_svg, capsys, text, message):
    (mine / "config.toml").write_text(text)
    assert main(["stat", str(plan_svg)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pencilbot: error: settings file ") and message in err and err.count("\n") == 1


def complete(script: Path, *words: str) -> list[str]:
    """What bash's completion function offers for the command line ``words`` (the last one being typed)."""
    line = " ".join(f"'{w}'" for w in words)
    done = subprocess.run(
        [
            "bash",
            "-c",
            f"source {script}; COMP_WORDS=({line}); COMP_CWORD=$(({len(words)} - 1)); _pencilbot; "
            'printf "%s\\n" "${COMPREPLY[@]}"',
        ],
        capture_output=True,
        text=True,
        timeout=60,
        env={**os.environ, "PATH": f"{Path(sys.executable).parent}:{os.environ['PATH']}"},
    )
    assert done.returncode == 0, done.stderr
    return [w for w in done.stdout.splitlines() if w]


def test_bash_completes_commands_options_choices_and_names(mine, tmp_path, capsys):
    assert main(["completion", "bash"]) == 0
    script = tmp_path / "pencilbot.bash"
    script.write_text(capsys.readouterr().out)
    (mine / "plotters" / "grbl-mine.toml").write_text(
        shipped("grbl-servo-a4")
    )  # added after the script was made
    assert complete(script, "pencilbot", "s") == ["sketch", "stat", "simulate", "sim-serve", "studio"]
    assert complete(script, "pencilbot", "export", "--keep") == ["--keep-order"]
    assert complete(script, "pencilbot", "plan", "--keep") == []  # plan has no such option
    assert complete(script, "pencilbot", "export", "photo.jpg", "--profile", "grbl") == [
        "grbl-mine",
        "grbl-servo-a4",
        "grbl-z-a3",
        "grblhal-servo-a3",
    ]
    assert complete(script, "pencilbot", "plan", "--style", "") == ["default", "outline", "sketchy"]
    assert complete(script, "pencilbot", "plan", "--orientation", "l") == ["landscape"]
    assert complete(script, "pencilbot", "completion", "") == ["bash", "zsh", "fish"]


def test_zsh_and_fish_scripts_cover_every_command(capsys):
    from pencilbot.commands import build_parser
    from pencilbot.commands.completion import describe

    commands = describe(build_parser())
    assert main(["completion", "fish"]) == 0
    lines = capsys.readouterr().out.splitlines()
    for name, command in commands.items():
        assert any(f"-n __fish_use_subcommand -a {name} " in line for line in lines)
        its = [line for line in lines if f"__fish_seen_subcommand_from {name}'" in line]
        for option in command["options"]:
            for string in option["strings"]:
                flag = f"-l {string[2:]} " if string.startswith("--") else f"-s {string[1:]} "
                assert any(flag in line for line in its), (name, string)
    assert any("-l profile -x -a '(pencilbot completion --names profiles)'" in line for line in lines)
    assert main(["completion", "zsh"]) == 0
    zsh = capsys.readouterr().out
    assert zsh.startswith("#compdef pencilbot\nautoload -U +X bashcompinit && bashcompinit\n")
    assert main(["completion", "bash"]) == 0
    assert zsh.endswith(capsys.readouterr().out.split("\n", 0)[0].split("# pencilbot shell completion", 1)[1])


@pytest.mark.parametrize("shell", ["bash", "zsh", "fish"])
def test_each_script_is_valid_in_its_shell(shell, capsys):
    if shutil.which(shell) is None:
        pytest.skip(f"{shell} is not installed here: its script's syntax is not checked")
    assert main(["completion", shell]) == 0
    checked = subprocess.run(
        [shell, "-n"], input=capsys.readouterr().out, capture_output=True, text=True, timeout=60
    )
    assert checked.returncode == 0, checked.stderr


def test_the_user_folder_is_not_the_tests_own(monkeypatch):
    # conftest gives every test an empty folder of its own: no user's profile leaks into a test.
    assert "pytest" in str(configs_io.user_folder()) and not (user_folder() / "plotters").exists()
