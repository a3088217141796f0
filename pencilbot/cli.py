"""Command-line entry point: a thin dispatcher over ``pencilbot.commands``.

Each subcommand lives in its own module under :mod:`pencilbot.commands` and exposes
``add_parser(subparsers)`` (which registers the parser and sets ``func``); the parser is
:func:`pencilbot.commands.build_parser`. User errors
(:class:`~pencilbot.errors.PencilbotError`) print one line and exit non-zero, never a traceback.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
import platform
import sys

from pencilbot.commands import COMMANDS, build_parser
from pencilbot.errors import PencilbotError


def _reuse_freed_memory() -> None:
    """Let glibc serve big arrays from the heap and keep freed memory for the next one.

    It maps every allocation over 32 MB afresh and unmaps it when freed, so each of the many
    image-sized temporaries of a 12 MP sketch pays its page faults again: about a third of the
    sketch's CPU time, all system time. The peak stays the same. Elsewhere nothing changes.

    NumPy also asks Linux for transparent huge pages for every array of 4 MB and more: each
    first touch then zeroes 2 MB, and once the machine has sat idle for a few seconds a 12 MP
    sketch spent 1.5 s of system time in those faults (0.6 s with 4 kB pages, measured
    with ``/usr/bin/time`` between pauses); so the CLI keeps to ordinary pages. NumPy reads the
    setting when it is imported, which has not happened yet here.
    """
    os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")
    if platform.libc_ver()[0] != "glibc":
        return
    libc = ctypes.CDLL(ctypes.util.find_library("c"))
    m_trim_threshold, m_mmap_threshold = -1, -3  # malloc.h
    libc.mallopt(m_mmap_threshold, 1 << 30)
    libc.mallopt(m_trim_threshold, 1 << 30)


def _printable_file_names() -> None:
    """A file name that is not UTF-8 (``os.fsdecode``'s surrogates) is printed escaped
    (``ph\\udcffoto.png``) in messages and ``-v`` logs, instead of failing to print at all."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.reconfigure(errors="backslashreplace")  # type: ignore[union-attr]
        except (AttributeError, ValueError, OSError):
            pass  # not a text stream of its own (a pipe wrapper, a closed terminal)


def main(argv: list[str] | None = None) -> int:
    _reuse_freed_memory()
    _printable_file_names()
    argv = sys.argv[1:] if argv is None else argv
    # Only the command being run is imported: all of them cost 0.2 s of start-up.
    named = argv[0].replace("-", "_") if argv else None
    try:
        # Inside: the parser reads the user's settings (default profile and style), and
        # --list-profiles / --list-styles read every profile and style.
        parser = build_parser(only=named if named in COMMANDS else None)
        args = parser.parse_args(argv)
        if not getattr(args, "func", None):
            parser.print_help()
            return 1
        from pencilbot.commands.common import refuse_overwriting

        refuse_overwriting(args)  # an output that is an input: refused before anything runs
        # -v shows pencilbot's own debug messages, not those of every library (Pillow, ...).
        logging.basicConfig(level=logging.WARNING, format="%(levelname)s: %(message)s")
        if getattr(args, "verbose", 0):
            for name in ("pencilbot", "sim", "firmware_protocol"):
                logging.getLogger(name).setLevel(logging.DEBUG)
        return int(args.func(args) or 0)
    except PencilbotError as err:
        try:
            print(f"pencilbot: error: {err}", file=sys.stderr)
        except OSError:
            pass  # the terminal is gone (SIGHUP): a stopped plot's journal keeps the resume command
        return err.exit_code
    except KeyboardInterrupt:
        print("pencilbot: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. `head`, which stopped reading
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
