"""Values a user gives the Python API (a notebook's ``mass="70kg"``, a path where a loaded trial
is taken): one rule, one message each; and the one way a standard error is written for a
reader (:func:`se_text`)."""

from __future__ import annotations

import dataclasses
import difflib
import functools
import math
import numbers
import os

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


def given(value) -> str:
    """What a message says the user gave: the type, and for a path or a text its value (a
    notebook's ``describe_trial("walk.c3d")`` is told it gave ``str 'walk.c3d'``)."""
    if isinstance(value, str | os.PathLike):
        return f"{type(value).__name__} {str(value)!r:.80}"
    return type(value).__name__


def require(value, kind: type | tuple[type, ...], takes: str, fix: str) -> None:
    """An :class:`InputError` unless ``value`` is a ``kind``: ``"{takes}, but got {given}:
    {fix}"``, e.g. ``takes`` "describe_trial takes one loaded trial" and ``fix`` the call that
    makes one. Python's own error for a wrong type comes from deep inside (an AttributeError
    on the first attribute read), naming neither the argument nor the fix."""
    if not isinstance(value, kind):
        raise InputError(f"{takes}, but got {given(value)}: {fix}")


def require_given(value, kind: type, what: str) -> None:
    """:func:`require` for a keyword that takes a settings dataclass of the package's top level
    (``weights=gc_ocp.Weights(...)``, ``options=gc_ocp.IpoptOptions(...)``) or None (its
    defaults); a dict of its fields, the usual slip, is told the call that takes them."""
    if value is None:
        return
    name = kind.__name__
    kw = f"**{value!r:.60}" if isinstance(value, dict) else "..."
    require(value, kind, f"{what} takes gc_ocp.{name} (or None)", f"{what}=gc_ocp.{name}({kw})")


def named_fields(cls: type) -> type:
    """A settings dataclass (``gc_ocp.IpoptOptions``, ``gc_ocp.Weights``) whose unknown keyword
    is an :class:`InputError` naming its fields and the closest one (``IpoptOptions(max_iters=50)``
    was Python's TypeError, which lists no field). Applied above ``@dataclass``."""
    init = cls.__init__
    names = [f.name for f in dataclasses.fields(cls)]

    @functools.wraps(init)
    def __init__(self, *args, **kw):
        unknown = [k for k in kw if k not in names]
        if unknown:
            close = difflib.get_close_matches(unknown[0], names, 1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise InputError(
                f"gc_ocp.{cls.__name__} has no field {unknown[0]!r}{hint}; its fields: "
                f"{', '.join(names)}"
            )
        init(self, *args, **kw)

    cls.__init__ = __init__
    return cls


def is_count(value) -> bool:
    """``value`` is a whole number given as one (a Python or NumPy integer), not a boolean
    (``True`` is an int) nor a float that happens to be whole."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def two_digits(x) -> str:
    """``x`` to two significant digits, written out as a reader writes a standard error
    (``230``, ``7800``, ``0.088``) where ``.2g`` gives ``2.3e+02``; trailing zeros dropped as
    ``.2g`` drops them (``0.5``); the exponent form only outside 1e-4 to 1e6, and a non-finite
    number as ``.2g`` writes it."""
    x = float(x)
    if not math.isfinite(x) or x == 0.0:
        return format(x, ".2g")
    e = math.floor(math.log10(abs(x)))
    if e < -4 or e >= 6:
        return format(x, ".2g")
    r = round(x, 1 - e)
    e = math.floor(math.log10(abs(r)))  # 9.96 rounds to 10: one decimal fewer
    text = format(r, f".{max(0, 1 - e)}f")
    return text.rstrip("0").rstrip(".") if "." in text else text  # 0.50 -> 0.5, as .2g


def se_text(se, value_text: str) -> str:
    """A standard error as its value is written beside it: in the exponent form where the value
    is (``3.896e+04 ± 6.4e+03``), else written out (``704 ± 230``, :func:`two_digits`), so
    that a row never mixes the two (``704 ± 2.3e+02`` was hard to read)."""
    if "e" in value_text.replace("–", "") and not value_text.strip().isalpha():
        return format(float(se), ".2g")
    return two_digits(se)


BOUND_TEXT = "(at its bound: not an estimate)"
"""What a table shows in place of ``± SE`` for a parameter flagged ``at_bound`` (its SE assumes
an interior optimum and means nothing there)."""

MINIMUM_TEXT = "(another minimum lies beyond this SE: see the flags)"
"""What a table adds after ``± SE`` for a parameter a ``minimum_undecided`` flag names: another
minimum the plates do not prefer the kept one to lies more than 2 SE away
(:func:`gc_ocp.estimation.starts.undecided_minimum`)."""
