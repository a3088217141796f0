"""Files and the operating system: atomic writes (a failure never leaves a half-written file),
outputs that would overwrite inputs, and the memory this process can still get."""

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
    refuse_special_output(target, folder_ok=True)  # (a folder: the rename below fails, "Is a directory")
    folder = target.parent
    if not folder.is_dir():
        raise PencilbotError(f"cannot write {target}: folder {folder} does not exist; create it first")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise PencilbotError(
            f"cannot write {target} ({exc.strerror}); check the folder's permissions"
        ) from None
    try:
        with os.fdopen(fd, "wb") as handle:
            yield handle
            os.fchmod(handle.fileno(), _MODE)
        os.replace(tmp, target)
    except BaseException as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise PencilbotError(
                f"cannot write {target} ({exc.strerror}); check the path and free space"
            ) from None
        raise


def check_writable(path: str | os.PathLike) -> None:
    """Make sure a file can be written at ``path`` later, by creating and removing a temporary
    one beside it now: a session that saves its result only at exit must not learn then that
    the folder is read-only or missing.

    Raises
    ------
    PencilbotError
        The folder does not exist or cannot be written.
    """
    try:
        with atomic_writer(path):
            raise _Probe  # the temporary file is made, then removed: nothing is written
    except _Probe:
        pass


class _Probe(Exception):
    """Abandons :func:`check_writable`'s temporary file (the block raising removes it)."""


#: The most bytes of a text file read whole (a profile, a style, a journal, config.toml): a
#: thousand times the largest real one; a longer "config" is another kind of file.
MAX_TEXT_FILE = 16 << 20


def _not_a_file(path) -> str | None:
    """What ``path`` is when it exists and is not a regular file (links followed): "a FIFO
    (named pipe)", "a device", "a folder", "a socket"; None for a file or nothing."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    return "a folder" if stat.S_ISDIR(mode) else "a socket" if stat.S_ISSOCK(mode) else "not a regular file"


def refuse_special_input(path, what: str = "input", folder_ok: bool = False) -> None:
    """Refuse to read ``path`` if it is a FIFO, a device, a folder or a socket: one blocks the
    reader forever (a FIFO nobody writes), one never ends (``/dev/zero``), one is no file at all.
    A path that does not exist is left to the reader's own message; a folder is refused unless
    ``folder_ok`` (a command that reads a folder of photos).

    Raises
    ------
    PencilbotError
        Naming the path, what it is and what to give instead.
    """
    kind = _not_a_file(path)
    if kind is not None and not (folder_ok and kind == "a folder"):
        raise PencilbotError(f"the {what} {path} is {kind}, not a file; give the path of a regular file")


def refuse_special_output(path, folder_ok: bool = False) -> None:
    """Refuse to write ``path`` if it exists and is not a regular file: a FIFO or a device node
    named as an output would be replaced by a file (and the folder of a symbolic link's target
    never checked), a folder cannot be (unless ``folder_ok``: a command that writes into one).

    Raises
    ------
    PencilbotError
        Naming the path and what it is.
    """
    kind = _not_a_file(path)
    if kind is not None and not (folder_ok and kind == "a folder"):
        raise PencilbotError(
            f"the output {path} is {kind}, not a file; pencilbot writes only regular files: "
            "name a file (a new one, or one to replace)"
        )


def read_bounded(path, what: str, limit: int = MAX_TEXT_FILE) -> bytes:
    """The bytes of the regular file ``path``, refused before reading if it is not a regular file
    or is longer than ``limit`` bytes (and never more than ``limit`` read, if it grows meanwhile).

    Raises
    ------
    PencilbotError
        Not a regular file, or too long (naming ``what`` it is).
    OSError
        It cannot be opened or read (FileNotFoundError included): the caller's message.
    """
    refuse_special_input(path, what)
    with open(path, "rb") as handle:
        if os.fstat(handle.fileno()).st_size > limit or len(data := handle.read(limit + 1)) > limit:
            raise PencilbotError(
                f"the {what} {path} is longer than {limit >> 20} MB, far more than any {what}; "
                "is it the right file?"
            )
    return data


def refuse_overwriting_inputs(inputs, outputs) -> None:
    """Refuse to write any of ``outputs`` that is one of ``inputs``: the same path, a hard link
    or a symbolic link to it (the same device and inode, as ``os.path.samefile`` compares), before
    anything runs. Paths that do not exist (yet) are skipped: a new file cannot be an input.
    Inputs that are FIFOs, devices, folders or sockets are refused too, and outputs that exist
    and are not regular files (:func:`refuse_special_input`, :func:`refuse_special_output`).

    Raises
    ------
    PencilbotError
        Naming the output and the input it would replace, or the special file.
    """
    inputs, outputs = [p for p in inputs if p is not None], [p for p in outputs if p is not None]
    for source in inputs:
        refuse_special_input(source, folder_ok=True)  # (a folder of photos; a file reader refuses one)
    for output in outputs:
        refuse_special_output(output, folder_ok=True)
    sources: dict[tuple[int, int] | None, Path] = {}
    for source in inputs:
        if source is not None and (key := _file_key(source)) is not None:
            sources.setdefault(key, Path(source))
    for output in outputs:
        if output is None or (source := sources.get(_file_key(output))) is None:
            continue
        also = "" if str(source) == str(output) else f" (the same file as the input {source})"
        raise PencilbotError(
            f"the output {output} is an input{also}: writing it would destroy it; name another output"
        )


def _file_key(path) -> tuple[int, int] | None:
    """(device, inode) of the regular file ``path`` (links followed), None if there is none."""
    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return None
    return (info.st_dev, info.st_ino) if stat.S_ISREG(info.st_mode) else None


def available_memory() -> tuple[int, str]:
    """Bytes this process can still allocate now, and what sets that figure (for messages).

    The least of: the memory the machine has available (``MemAvailable``), what is left of the
    container's limit (cgroup v2 ``memory.max`` less ``memory.current``; v1's
    ``memory.limit_in_bytes`` less its usage), and what is left of the process's address-space
    limit (``RLIMIT_AS``, ``ulimit -v``, less its ``VmSize``). A process under an 8 GB ``ulimit``
    on a 64 GB machine has under 8 GB, not 64.

    Returns
    -------
    bytes : int
    words : str
        e.g. ``"this machine has free"``, ``"left under this process's limit, ulimit -v"``.
    """
    found = [(_meminfo("MemAvailable"), "this machine has free")]
    for limit_file, usage_file in (
        ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
        ("/sys/fs/cgroup/memory/memory.limit_in_bytes", "/sys/fs/cgroup/memory/memory.usage_in_bytes"),
    ):
        limit, usage = _number_in(limit_file), _number_in(usage_file)
        if limit is not None and usage is not None and limit < 1 << 60:
            found.append((max(0, limit - usage), "left in the container's memory limit"))
            break
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    except (ImportError, OSError, ValueError):
        soft = -1
    if soft not in (-1, getattr(resource, "RLIM_INFINITY", -1)):
        used = _status_bytes("VmSize") or 0
        found.append((max(0, soft - used), "left under this process's limit, ulimit -v"))
    known = [(size, words) for size, words in found if size is not None]
    if not known:
        try:
            return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"), "this machine has free"
        except (ValueError, OSError, AttributeError):
            return 4 << 30, "a small machine has"  # unknown: assume one
    return min(known)


def _meminfo(key: str) -> int | None:
    return _kilobytes_in("/proc/meminfo", key)


def _status_bytes(key: str) -> int | None:
    return _kilobytes_in("/proc/self/status", key)


def _kilobytes_in(path: str, key: str) -> int | None:
    """The ``key: N kB`` line of a /proc file, in bytes."""
    try:
        with open(path, encoding="ascii") as lines:
            for line in lines:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _number_in(path: str) -> int | None:
    """The number a cgroup file holds; None when it is missing or says ``max``."""
    try:
        with open(path, encoding="ascii") as handle:
            return int(handle.read().strip())
    except (OSError, ValueError):
        return None
