"""Output paths, checked before any solve: an output never overwrites an input and lies where a file can be made.

A command that refused its output after minutes of solving would lose the work, and one that wrote over its
measurement file would lose the data; so every command checks its outputs against the config's inputs (the
config file, the ``[data]`` files, the mesh file and the files it includes) first. A folder that does not exist
yet is made when the output is written (as ``[run] dir`` is), never on a refusal; a path running under a file
is refused.
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import InputError


def input_files(config) -> list[Path]:
    """The files a config reads: the config itself, the ``[data]`` files and the mesh file with its includes."""
    from .builders.registry import source_files
    from .data.sources import data_paths

    files = [] if config.name is not None else [config.path]
    if config.data.file is not None:
        try:
            files += data_paths(config.data, config.resolve)
        except (KeyError, TypeError):       # a malformed entry: [data]'s own check names it
            pass
    mesh = config.model.option("file")
    if isinstance(mesh, str) and os.path.isfile(mesh):
        files += list(source_files(mesh))
    return files


def _same(a: Path, b: Path) -> bool:
    if a.exists() and b.exists():
        return os.path.samefile(a, b)
    return a.resolve() == b.resolve()


def _existing_ancestor(path: Path) -> Path:
    """The deepest existing folder or file on the way to ``path`` (``path`` itself when it exists)."""
    path = path.absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def check_file(path: str | Path, inputs, what: str) -> Path:
    """``path`` as an absolute Path when a file can be written there without overwriting an input.

    ``what`` names the output in messages (e.g. "--out"). Refused: an input file, an existing folder, a path
    under a file, a folder that cannot be written. A missing folder on the way is fine (made when writing).

    >>> check_file("/tmp/frictionid-doc/x.csv", [], "--out").name
    'x.csv'
    """
    path = Path(path).absolute()
    for source in inputs:
        if _same(path, Path(source)):
            raise InputError(f"{what} {path}: is an input of this run ({source}); writing it would overwrite it. "
                             "Write to another file")
    if path.is_dir():
        raise InputError(f"{what} {path}: is a folder; give a file name")
    _writable_folder(path.parent, what, path)
    return path


def check_folder(path: str | Path, what: str, inputs=(), names=()) -> Path:
    """``path`` as an absolute Path when it can be a folder of outputs: an existing folder or one that can be
    made (not a file, not under a file), where none of the file ``names`` it will hold is an input."""
    path = Path(path).absolute()
    if path.exists() and not path.is_dir():
        raise InputError(f"{what} = {str(path)!r}: is a file, not a folder; name a folder for the outputs")
    _writable_folder(path, what, path)
    for name in names:
        check_file(path / name, inputs, f"{what} ({name})")
    return path


def _writable_folder(folder: Path, what: str, path: Path) -> None:
    found = _existing_ancestor(folder)
    if not found.is_dir():
        raise InputError(f"{what} {str(path)!r}: {found} is a file, so no folder can be made under it")
    if not os.access(found, os.W_OK | os.X_OK):
        raise InputError(f"{what} {str(path)!r}: the folder {found} cannot be written")
