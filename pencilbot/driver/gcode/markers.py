"""What G-code from other tools carries around its commands and no board must be sent.

Inkscape, LaserGRBL and CAM post-processors write a UTF-8 byte-order mark at the start and ``%``
tape markers on the first and last lines. GRBL has no use for either (a ``%`` is error:1, the
BOM's bytes are not ASCII); senders leave them out, and so does the driver. The lines stay,
empty, so messages keep the file's line numbers.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator

_BOM = b"\xef\xbb\xbf"
_TAPE_MARKER = re.compile(rb"(?m)^[ \t]*%[ \t]*(?:[;(][^\r\n]*)?(?=\r?$)")


def without_markers(blocks: Iterable[bytes]) -> Iterator[bytes]:
    """``blocks`` of whole lines (the first one the file's start) without a leading byte-order
    mark and with ``%`` lines (a marker, maybe a comment after it) left empty."""
    for n, block in enumerate(blocks):
        yield _TAPE_MARKER.sub(b"", block.removeprefix(_BOM) if n == 0 else block)
