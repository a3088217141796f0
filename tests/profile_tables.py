"""Plotter profiles as tables, for tests that change one key: a shipped profile's table, and a
table written back as TOML (shared by tests/machine, tests/hostile and bench/hostile.py)."""

import json
import tomllib

from pencilbot.configs_io import config_folder


def shipped_table(name: str = "grbl-servo-a4") -> dict:
    text = (config_folder("plotters") / f"{name}.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)


def toml_text(table: dict) -> str:
    """Just enough TOML for profile tables (JSON strings are valid TOML basic strings; Python's
    ``nan``, ``inf`` and ``-inf`` are TOML's)."""

    def value(v) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    top = [f"{k} = {value(v)}" for k, v in table.items() if not isinstance(v, dict)]
    tables = [
        f"[{k}]\n" + "\n".join(f"{kk} = {value(vv)}" for kk, vv in v.items())
        for k, v in table.items()
        if isinstance(v, dict)
    ]
    return "\n".join(top) + "\n\n" + "\n\n".join(tables) + "\n"
