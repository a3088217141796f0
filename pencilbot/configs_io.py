"""Reading the TOML files behind profiles and styles: shipped by name, or any file by path.

The shipped files live in the repository's top-level ``configs/`` folder (``plotters/``,
``styles/``). The wheel carries that folder as ``pencilbot/configs/``; a source checkout run in
place (``python -m pencilbot.cli`` from a clone, or an editable install) reads it where it is.
:func:`config_folder` knows both places, so nothing else has to.
"""

from __future__ import annotations

from pathlib import Path

from pencilbot.errors import ProfileError

_PACKAGE = Path(__file__).resolve().parent
#: Where the shipped configs may be, in order: inside an installed package, then beside the
#: package in a source checkout.
CONFIG_ROOTS = (_PACKAGE / "configs", _PACKAGE.parent / "configs")


def config_folder(folder: str) -> Path:
    """The shipped ``configs/<folder>`` (``"plotters"`` or ``"styles"``).

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


def read_config_text(folder: str, name_or_path: str, *, kind: str, file_kind: str) -> tuple[str, str, str]:
    """The TOML text of a shipped config or a file, where it came from, and its name.

    Parameters
    ----------
    folder : str
        ``"plotters"`` or ``"styles"`` under ``configs``.
    name_or_path : str
        A shipped name, or a path (anything ending in ``.toml`` or naming a folder).
    kind, file_kind : str
        Words for messages: e.g. ``"style"`` and ``"style file"``.

    Raises
    ------
    ProfileError
        No such shipped name, or the file cannot be read.
    """
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.parent != Path("."):
        try:
            return path.read_text(encoding="utf-8"), str(path), path.stem
        except (OSError, UnicodeDecodeError) as exc:
            reason = getattr(exc, "strerror", None) or str(exc)
            raise ProfileError(f"cannot read {file_kind} {path} ({reason}); check the path") from None
    shipped = config_folder(folder) / f"{name_or_path}.toml"
    if not shipped.is_file():
        raise ProfileError(
            f"no {kind} named {name_or_path!r}; choose one of {', '.join(shipped_names(folder))} "
            "or give a path to a .toml file"
        )
    return shipped.read_text(encoding="utf-8"), f"{folder}/{name_or_path}.toml", name_or_path
