"""Reading the TOML files behind profiles and styles: shipped by name, or any file by path."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from pencilbot.errors import ProfileError


def shipped_names(folder: str) -> list[str]:
    """Names (without ``.toml``) of the files shipped in ``pencilbot/configs/<folder>``, sorted."""
    files = resources.files("pencilbot.configs").joinpath(folder)
    return sorted(p.name[: -len(".toml")] for p in files.iterdir() if p.name.endswith(".toml"))


def read_config_text(folder: str, name_or_path: str, *, kind: str, file_kind: str) -> tuple[str, str, str]:
    """The TOML text of a shipped config or a file, where it came from, and its name.

    Parameters
    ----------
    folder : str
        ``"plotters"`` or ``"styles"`` under ``pencilbot/configs``.
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
    shipped = resources.files("pencilbot.configs").joinpath(folder, f"{name_or_path}.toml")
    if not shipped.is_file():
        raise ProfileError(
            f"no {kind} named {name_or_path!r}; choose one of {', '.join(shipped_names(folder))} "
            "or give a path to a .toml file"
        )
    return shipped.read_text(encoding="utf-8"), f"{folder}/{name_or_path}.toml", name_or_path
