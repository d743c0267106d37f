"""One exception hierarchy for gc_ocp.

Every error raised on bad user input is a :class:`GcOcpError` subclass whose message
names the offending input (file, marker, plate, unit) and the fix. The CLI prints the
message without a traceback and exits with status 2 (1 for a :class:`SolveError`).

Which to catch: :class:`InputError` for what the user gave (a file, an option, an array: the
message says what to change; :class:`MarkerError`, :class:`PlateError`, :class:`UnitsError`
narrow it); :class:`SolveError` for a fit Ipopt did not bring to convergence (its ``.result``
holds the last iterate); :class:`GcOcpError` for every error the package raises on purpose.
A trial given without its kinematics, for example:

>>> import gc_ocp
>>> trial = gc_ocp.load_trial()               # the bundled example
>>> try:                                      # doctest: +ELLIPSIS
...     report = gc_ocp.fit([trial])
... except gc_ocp.SolveError as e:
...     print(e, e.result.status)             # what was obtained, to inspect or restart from
... except gc_ocp.InputError as e:
...     print(e)                              # names the input and the fix
item 0 of the trials is a Trial without its kinematics; give a list of (trial, kinematics) pairs: ...
"""

from __future__ import annotations


class GcOcpError(Exception):
    """Base class of every error gc_ocp raises on purpose: ``except gc_ocp.GcOcpError`` takes
    them all (an error of another type from inside gc_ocp is a bug, as the CLI says)."""


class InputError(GcOcpError, ValueError):
    """A file, option or array given by the user is unusable (names it and the fix): the one to
    catch around a call on user input (also a ``ValueError``).

    >>> import gc_ocp
    >>> path = "walk.c3d"                     # a file that is not there
    >>> try:
    ...     trial = gc_ocp.load_trial(path)
    ... except gc_ocp.InputError as e:
    ...     print(f"skipped {path}: {e}")     # doctest: +ELLIPSIS
    skipped walk.c3d: Trial file walk.c3d does not exist; give a trial's .c3d file, ...
    """


class MarkerError(InputError):
    """A marker is missing, has long gaps, or is not in the marker set."""


class PlateError(InputError):
    """A force plate is missing, unusable, or a stance is not fully on it."""


class UnitsError(InputError):
    """Values look like the wrong unit (e.g. millimetres where metres are expected)."""


class MassError(InputError):
    """The subject's mass disagrees with what the plates carry (a property of the subject, not
    of one trial: never skipped as one trial's problem)."""


class ModelError(GcOcpError):
    """The body model or contact layout is inconsistent, or a model assembled in code cannot be
    made (e.g. a :class:`~gc_ocp.estimation.components.contact.Param` of unknown scope, a
    component name registered twice); an unknown name is also an :class:`InputError`
    (:class:`UnknownNameError`)."""


class UnknownNameError(InputError, ModelError):
    """A name the user gave (an effect, a component, a base) that the package does not know:
    bad input (an :class:`InputError`, which a notebook's ``except InputError`` and the CLI's
    exit status 2 take) and a model that cannot be made (a :class:`ModelError`, as before)."""


def names_of(value, what: str) -> list[str]:
    """``value`` as a list of names: one string is one name (``"damping"``, not its letters);
    anything but strings is refused naming ``what``."""
    names = [value] if isinstance(value, str) else list(value)
    bad = [n for n in names if not isinstance(n, str)]
    if bad:
        raise InputError(f"{what} are names (strings), but got {bad[0]!r}")
    return names


def read_document(read, what: str, fix: str):
    """``read()``, the reading of a JSON document the package wrote (a fit.json, a
    diagnosis.json), with what an edited, truncated or foreign document raises there (a missing
    key, a value of the wrong type, a JSON error) turned into an :class:`InputError`: ``what``
    is wrong, the exception, and the ``fix``."""
    try:
        return read()
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as e:
        if isinstance(e, InputError):
            raise
        raise InputError(f"{what} ({type(e).__name__}: {e}); {fix}") from None


class RankError(GcOcpError, ValueError):
    """A linear system has no unique solution (rank deficient)."""


class SolveError(GcOcpError, RuntimeError):
    """A numerical solve failed or did not converge; ``.result`` carries what was obtained (an
    :class:`~gc_ocp.estimation.result.EstimationResult` for an Ipopt fit). Five iterations
    are too few for the seed's model on the bundled trial:

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)
    >>> problem = gc_ocp.build_estimation(gc_ocp.trial_stances(trial, kin), gc_ocp.seed_model())
    >>> try:
    ...     result = gc_ocp.solve(problem, gc_ocp.IpoptOptions(max_iter=5))
    ... except gc_ocp.SolveError as e:
    ...     print(e)
    ...     result = e.result                 # status, iterations and the last iterate
    Ipopt did not converge: Maximum_Iterations_Exceeded after 5 iterations
    >>> result.status, result.iterations
    ('Maximum_Iterations_Exceeded', 5)
    """

    def __init__(self, message: str, result: object = None) -> None:
        super().__init__(message)
        self.result = result


def require_file(path, what: str, fix: str) -> None:
    """Raise :class:`InputError` unless ``path`` is a file: ``what`` names it (``"Trial
    file"``), ``fix`` says what to give instead; a folder is named as a folder (a folder given
    where a file belongs is the usual slip, and "does not exist" would send the user looking
    for a typo)."""
    from pathlib import Path

    path = Path(path)
    if path.is_file():
        return
    if path.is_dir():
        raise InputError(f"{what} {path} is a folder, not a file; {fix}")
    raise InputError(f"{what} {path} does not exist; {fix}")
