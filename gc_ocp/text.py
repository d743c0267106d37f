"""Reading the text files a user writes (manifests, marker sets): one encoding rule."""

from __future__ import annotations

from pathlib import Path

from gc_ocp.errors import InputError


def read_utf8(path: str | Path, what: str) -> str:
    """The text of ``path`` (UTF-8, a byte-order mark allowed), or an :class:`InputError` naming
    the file and the fix when it is in another encoding (a spreadsheet's CSV saved as Latin-1)."""
    try:
        return Path(path).read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError(
            f"{what} {path} is not UTF-8 text (byte {e.object[e.start]:#04x} at position "
            f"{e.start}); save it as UTF-8 (in a spreadsheet: CSV UTF-8)."
        ) from None
