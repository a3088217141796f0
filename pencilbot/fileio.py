"""Writing output files so that a failure never leaves a half-written file behind."""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

from pencilbot.errors import PencilbotError


def _file_mode() -> int:
    """The permissions an ordinary new file gets here (0666 less the umask)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


_MODE = _file_mode()


def write_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder, then rename.

    Readers see either the old file or the whole new one. On any failure, Ctrl-C included,
    the temporary file is removed. The file gets the usual permissions (umask), not the
    private ones of a temporary file.

    Raises
    ------
    PencilbotError
        The folder does not exist or cannot be written.
    """
    with atomic_writer(path) as handle:
        handle.write(data)


@contextmanager
def atomic_writer(path: str | os.PathLike) -> Iterator[BinaryIO]:
    """A binary file to write ``path`` piece by piece; renamed into place when the block ends.

    What :func:`write_atomic` does for data that is made as it is written (a PNG band by band):
    if the block raises, the temporary file is removed and ``path`` is left as it was.

    Raises
    ------
    PencilbotError
        The folder does not exist or cannot be written.
    """
    target = Path(path)
    folder = target.parent
    if not folder.is_dir():
        raise PencilbotError(f"cannot write {target}: folder {folder} does not exist; create it first")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise PencilbotError(f"cannot write {target} ({exc.strerror}); check the folder's permissions") from None
    try:
        with os.fdopen(fd, "wb") as handle:
            yield handle
            os.fchmod(handle.fileno(), _MODE)
        os.replace(tmp, target)
    except BaseException as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise PencilbotError(f"cannot write {target} ({exc.strerror}); check the path and free space") from None
        raise



def refuse_overwriting_inputs(inputs, outputs) -> None:
    """Refuse to write any of ``outputs`` that is one of ``inputs``: the same path, a hard link
    or a symbolic link to it (the same device and inode, as ``os.path.samefile`` compares), before
    anything runs. Paths that do not exist (yet) are skipped: a new file cannot be an input.

    Raises
    ------
    PencilbotError
        Naming the output and the input it would replace.
    """
    sources = {}
    for source in inputs:
        if source is not None and (key := _file_key(source)) is not None:
            sources.setdefault(key, Path(source))
    for output in outputs:
        if output is None or (source := sources.get(_file_key(output))) is None:
            continue
        also = "" if str(source) == str(output) else f" (the same file as the input {source})"
        raise PencilbotError(f"the output {output} is an input{also}: writing it would destroy it; name another output")


def _file_key(path) -> tuple[int, int] | None:
    """(device, inode) of the regular file ``path`` (links followed), None if there is none."""
    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return None
    return (info.st_dev, info.st_ino) if stat.S_ISREG(info.st_mode) else None
