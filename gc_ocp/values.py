"""Numbers a user gives the Python API (a notebook's ``mass="70kg"``): one rule, one message."""

from __future__ import annotations

import math

from gc_ocp.errors import InputError


def number(value, what: str, unit: str, text: bool = True) -> float:
    """``value`` as a finite float (an int, a float or, with ``text``, a numeric string, as a
    CLI's option would be), else an :class:`InputError` that names ``what`` and its ``unit``: a
    string with a unit in it, a list, a boolean (``float(True)`` is 1). ``text=False`` for a
    file's typed value (a TOML number), where a string is a mistake of the file."""
    try:
        if isinstance(value, bool) or (not text and isinstance(value, str)):
            raise TypeError
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if not math.isfinite(x):
        raise InputError(f"{what} must be a number in {unit}, but got {value!r}")
    return x
