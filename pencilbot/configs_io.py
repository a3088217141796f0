"""Reading the TOML files behind profiles and styles: the user's or shipped, by name, or any file
by path; and the user's settings.

The shipped files live in the repository's top-level ``configs/`` folder (``plotters/``,
``styles/``, ``pens/``). The wheel carries that folder as ``pencilbot/configs/``; a source checkout run in
place (``python -m pencilbot.cli`` from a clone, or an editable install) reads it where it is.
:func:`config_folder` knows both places, so nothing else has to.

The user's own folder (:func:`user_folder`: ``$PENCILBOT_CONFIG_DIR`` if set, else the platform's
place for settings, e.g. ``~/.config/pencilbot``) has the same ``plotters/``, ``styles/`` and ``pens/``;
a name is looked up there first, so a user's profile may also replace a shipped one. Its
``config.toml`` holds the user's defaults (:data:`SETTINGS`).
"""

from __future__ import annotations

import os
import sys
import tomllib
from pathlib import Path

from pencilbot.errors import ProfileError
from pencilbot.fileio import read_bounded

_PACKAGE = Path(__file__).resolve().parent
#: Where the shipped configs may be, in order: inside an installed package, then beside the
#: package in a source checkout.
CONFIG_ROOTS = (_PACKAGE / "configs", _PACKAGE.parent / "configs")


def config_folder(folder: str) -> Path:
    """The shipped ``configs/<folder>`` (``"plotters"``, ``"styles"`` or ``"pens"``).

    Raises
    ------
    ProfileError
        Neither an installed nor a source-checkout copy is there (a broken installation).
    """
    for root in CONFIG_ROOTS:
        if (root / folder).is_dir():
            return root / folder
    raise ProfileError(
        f"pencilbot's shipped configs/{folder} folder is missing (looked in "
        f"{' and '.join(str(r) for r in CONFIG_ROOTS)}); reinstall pencilbot, or give a path to a .toml file"
    )


def shipped_names(folder: str) -> list[str]:
    """Names (without ``.toml``) of the files shipped in ``configs/<folder>``, sorted."""
    return sorted(p.stem for p in config_folder(folder).glob("*.toml"))


def user_folder() -> Path:
    """The user's pencilbot folder, by the platform's convention (it need not exist).

    ``$PENCILBOT_CONFIG_DIR`` if set; on Windows ``%APPDATA%\\pencilbot``; on macOS
    ``~/Library/Application Support/pencilbot``; elsewhere ``$XDG_CONFIG_HOME/pencilbot``,
    by default ``~/.config/pencilbot``.
    """
    if os.environ.get("PENCILBOT_CONFIG_DIR"):
        return Path(os.environ["PENCILBOT_CONFIG_DIR"]).expanduser().absolute()
    if sys.platform == "win32":
        return Path(os.environ.get("APPDATA") or Path.home() / "AppData" / "Roaming") / "pencilbot"
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Application Support" / "pencilbot"
    return Path(os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config") / "pencilbot"


def cache_folder() -> Path:
    """The user's folder for what pencilbot can always work out again (it need not exist).

    ``$PENCILBOT_CACHE_DIR`` if set; on Windows ``%LOCALAPPDATA%\\pencilbot\\cache``; on macOS
    ``~/Library/Caches/pencilbot``; elsewhere ``$XDG_CACHE_HOME/pencilbot``, by default
    ``~/.cache/pencilbot``.
    """
    if os.environ.get("PENCILBOT_CACHE_DIR"):
        return Path(os.environ["PENCILBOT_CACHE_DIR"]).expanduser().absolute()
    if sys.platform == "win32":
        return (
            Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local") / "pencilbot" / "cache"
        )
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches" / "pencilbot"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pencilbot"


def user_names(folder: str) -> list[str]:
    """Names of the user's own files in ``<user folder>/<folder>``, sorted."""
    return sorted(p.stem for p in (user_folder() / folder).glob("*.toml"))


def config_names(folder: str) -> dict[str, Path]:
    """Every name a profile or style may be given by, user's first: name → its file, sorted."""
    found = {name: config_folder(folder) / f"{name}.toml" for name in shipped_names(folder)}
    found.update({name: user_folder() / folder / f"{name}.toml" for name in user_names(folder)})
    return dict(sorted(found.items()))


#: What ``config.toml`` in the user folder may set: key → what it is the default of.
SETTINGS = {"profile": "the plotter profile", "style": "the drawing style"}
#: Its tables: ``[ports]`` names plotters (``big = "/dev/ttyUSB0"``: ``--port big``).
SETTING_TABLES = {"ports": 'plotter names, each a port (big = "/dev/ttyUSB0")'}


def user_setting(key: str) -> str | None:
    """The user's default for ``key`` (a key of :data:`SETTINGS`) from ``config.toml``, or None.

    A value is a name or a path to a ``.toml`` file (``~`` is the home folder; a relative path
    is relative to the user folder).

    Raises
    ------
    ProfileError
        The file is not valid TOML, has a key it should not, or a value that is no name.
    """
    value = _user_settings().get(key)
    if value is None or not _is_path(value):
        return value
    return str(user_folder() / Path(value).expanduser())  # an absolute path stays as it is


def user_ports() -> dict[str, str]:
    """The plotters the user named in ``config.toml``'s ``[ports]`` table: name → port."""
    return dict(_user_settings().get("ports", {}))


def _user_settings() -> dict:
    """``config.toml`` read and checked (empty when there is none)."""
    path = user_folder() / "config.toml"
    try:
        table = tomllib.loads(read_bounded(path, "settings file").decode("utf-8"))
    except FileNotFoundError:
        return {}
    except (OSError, UnicodeDecodeError) as exc:
        raise ProfileError(
            f"cannot read settings file {path} ({getattr(exc, 'strerror', None) or exc})"
        ) from None
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(f"settings file {path} is not valid TOML ({exc}); fix the syntax") from None
    for name, value in table.items():
        if name in SETTING_TABLES:
            if not isinstance(value, dict) or not all(
                isinstance(v, str) and v.strip() for v in value.values()
            ):
                raise ProfileError(f"settings file {path}: [{name}] must hold {SETTING_TABLES[name]}")
            continue
        if name not in SETTINGS:
            raise ProfileError(
                f"settings file {path} has unknown key {name!r}; the keys are: "
                f"{', '.join([*SETTINGS, *SETTING_TABLES])}"
            )
        if not isinstance(value, str) or not value.strip():
            raise ProfileError(
                f"settings file {path}: {name} = {value!r} is invalid; expected the name or .toml "
                f"path of {SETTINGS[name]}"
            )
    return table


def read_config_text(folder: str, name_or_path: str, *, kind: str, file_kind: str) -> tuple[str, str, str]:
    """The TOML text of a shipped config or a file, where it came from, and its name.

    Parameters
    ----------
    folder : str
        ``"plotters"``, ``"styles"`` or ``"pens"`` under ``configs``.
    name_or_path : str
        A name (the user's first, then the shipped), or a path (anything ending in ``.toml`` or
        naming a folder).
    kind, file_kind : str
        Words for messages: e.g. ``"style"`` and ``"style file"``.

    Raises
    ------
    ProfileError
        No such name, or the file cannot be read.
    """
    path = Path(name_or_path)
    if _is_path(name_or_path):
        try:
            return read_bounded(path, file_kind).decode("utf-8"), str(path), path.stem
        except (OSError, UnicodeDecodeError) as exc:
            reason = getattr(exc, "strerror", None) or str(exc)
            raise ProfileError(f"cannot read {file_kind} {path} ({reason}); check the path") from None
    own = user_folder() / folder / f"{name_or_path}.toml"
    if own.is_file():
        try:
            return read_bounded(own, file_kind).decode("utf-8"), str(own), name_or_path
        except (OSError, UnicodeDecodeError) as exc:
            raise ProfileError(
                f"cannot read {file_kind} {own} ({getattr(exc, 'strerror', None) or exc})"
            ) from None
    shipped = config_folder(folder) / f"{name_or_path}.toml"
    if not shipped.is_file():
        raise ProfileError(
            f"no {kind} named {name_or_path!r}; choose one of {', '.join(config_names(folder))}, "
            f"give a path to a .toml file, or put {name_or_path}.toml in {user_folder() / folder}"
        )
    return shipped.read_text(encoding="utf-8"), f"{folder}/{name_or_path}.toml", name_or_path


def read_config_table(folder: str, name_or_path: str, *, kind: str, file_kind: str) -> tuple[dict, str, str]:
    """:func:`read_config_text` parsed: the TOML table, where it came from, and its name.

    Raises
    ------
    ProfileError
        As :func:`read_config_text`, or the text is not valid TOML.
    """
    text, where, stem = read_config_text(folder, name_or_path, kind=kind, file_kind=file_kind)
    try:
        return tomllib.loads(text), where, stem
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(f"{file_kind} {where} is not valid TOML ({exc}); fix the syntax") from None


def _is_path(name_or_path: str) -> bool:
    """Whether a profile or style is given as a file rather than by name."""
    path = Path(name_or_path)
    return path.suffix == ".toml" or path.parent != Path(".")
