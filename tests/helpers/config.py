r"""Config files written by tests: each table a dict (values written as TOML) or TOML lines as text.

>>> print(config_text(model={"builder": "block2d", "mesh_size": 2.0}, friction={"zones": {"A": 0.1}},
...                   identify='method = "trf"\n'), end="")
[model]
builder = "block2d"
mesh_size = 2.0
[friction]
zones = { A = 0.1 }
[identify]
method = "trf"
"""

from __future__ import annotations

import json
from pathlib import Path


def toml_value(value) -> str:
    """``value`` as a TOML value: tables inline (``{ A = 0.1 }``), strings quoted.

    >>> toml_value({"u": 5e-4, "*": "base"}), toml_value([1, 2.5, "x", True])
    ('{ u = 0.0005, "*" = "base" }', '[1, 2.5, "x", true]')
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, dict):
        items = ", ".join(f"{_key(k)} = {toml_value(v)}" for k, v in value.items())
        return f"{{ {items} }}" if items else "{}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    raise TypeError(f"no TOML value for {value!r}")


def _key(key: str) -> str:
    return key if key.replace("_", "").replace("-", "").isalnum() else json.dumps(key)


def config_text(extra: str = "", **tables: dict | str | None) -> str:
    """The text of a config with the given [tables] in order (None leaves a table out, a string is its lines),
    then ``extra``: TOML text with headers of its own."""
    parts = []
    for name, body in tables.items():
        if body is None:
            continue
        text = body if isinstance(body, str) else "".join(f"{_key(k)} = {toml_value(v)}\n" for k, v in body.items())
        parts.append(f"[{name}]\n{text}" + ("\n" if text and not text.endswith("\n") else ""))
    return "".join(parts) + extra


def write_config(path: str | Path, extra: str = "", **tables: dict | str | None) -> Path:
    """Write :func:`config_text` to ``path``; the path."""
    path = Path(path)
    path.write_text(config_text(extra, **tables))
    return path


def with_data(folder: str | Path, name: str, **data) -> Path:
    """``folder``/<name>.toml: ``folder``'s identify.toml (e.g. a copy of examples/first) with the [data] keys
    ``data`` changed and run.dir runs/<name>."""
    import tomllib

    import tomli_w

    folder = Path(folder)
    config = tomllib.loads((folder / "identify.toml").read_text())
    config["data"].update(data)
    config["run"]["dir"] = f"runs/{name}"
    path = folder / f"{name}.toml"
    path.write_text(tomli_w.dumps(config))
    return path
