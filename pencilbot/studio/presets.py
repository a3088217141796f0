"""The page's presets: named settings (the drawing options and the placement) kept as JSON in the
user's config folder (:func:`~pencilbot.configs_io.user_folder` ``/studio-presets``).

A name is checked (letters, digits, space, ``-`` and ``_``): it is never taken as a path. What a
preset holds goes through the same checks as the page's own requests when it is loaded.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from pencilbot.configs_io import user_folder
from pencilbot.errors import PencilbotError

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9 _-]{0,39}")
#: Presets one folder may hold (each a few hundred bytes).
MAX_PRESETS = 200


def folder() -> Path:
    return user_folder() / "studio-presets"


def _path(name: str) -> Path:
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise PencilbotError(
            f"preset name {name!r}: use up to 40 letters, digits, spaces, - or _, starting with a letter or digit"
        )
    return folder() / f"{name}.json"


def names() -> list[str]:
    """The saved presets' names, sorted."""
    here = folder()
    return sorted(p.stem for p in here.glob("*.json") if _NAME.fullmatch(p.stem)) if here.is_dir() else []


def save(name: str, settings: dict) -> Path:
    """Keep ``settings`` (JSON-able) as preset ``name`` (replacing one of that name)."""
    path = _path(name)
    if not path.exists() and len(names()) >= MAX_PRESETS:
        raise PencilbotError(f"there are {MAX_PRESETS} presets already; delete one first")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(settings, indent=1, sort_keys=True), encoding="utf-8")
    except OSError as err:
        raise PencilbotError(f"cannot save the preset in {path.parent} ({err.strerror or err})") from None
    return path


def load(name: str) -> dict:
    path = _path(name)
    try:
        settings = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise PencilbotError(f"there is no preset called {name}") from None
    except (OSError, ValueError):
        raise PencilbotError(f"the preset {name} cannot be read; save it again") from None
    if not isinstance(settings, dict):
        raise PencilbotError(f"the preset {name} cannot be read; save it again")
    return settings


def delete(name: str) -> None:
    _path(name).unlink(missing_ok=True)
