"""Reading the text files a user gives (manifests, marker sets, the JSON documents the package
wrote: fit.json, diagnosis.json): one encoding rule, one reader of a JSON file."""

from __future__ import annotations

import json
from pathlib import Path

from gc_ocp.errors import InputError, require_file


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


def read_json_file(path: str | Path, what: str, document: str, fix: str):
    """The parsed JSON of the file ``path``: ``what`` names the file in a missing-file message
    (``"Fit file"``), ``document`` what it should be (``"a fit.json"``) and ``fix`` what to
    give; a missing file, a folder, text not in UTF-8 or not JSON is an :class:`InputError`
    that says so."""
    path = Path(path)
    require_file(path, what, fix)
    try:
        return json.loads(read_utf8(path, what))
    except json.JSONDecodeError as e:
        raise InputError(f"{path} is not {document} ({e}); {fix}") from None
