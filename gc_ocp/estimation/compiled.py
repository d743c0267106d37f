"""SX functions compiled to C, cached on disk (generic: imports nothing else of gc_ocp).

The estimator evaluates three small SX functions on every frame at every Ipopt iteration: the
weighted residual, its gradient and its exact Hessian in the per-frame inputs (the Hessian has
~30k operations and dominates the solve time). CasADi's SX virtual machine evaluates them; the
same functions generated as C (:class:`casadi.CodeGenerator`) and compiled with the system C
compiler run ~5x faster (measured: ``benchmarks/fit_speed.py``). Results are identical to
round-off (tested).

Compiling takes ~10-20 s (``-O1``), so the shared library is cached and reused by every later
process: the file name is a hash of the generated C source, the compiler and its flags, so a
change of the model, of CasADi or of the flags compiles a new one. The library is written to a
temporary name and renamed into place, so concurrent processes never load a half-written file.

Settings (environment variables):

* ``GC_OCP_COMPILE=0`` — never compile; use CasADi's SX virtual machine (same results, slower).
* ``GC_OCP_CACHE_DIR`` — cache directory (default ``$XDG_CACHE_HOME/gc_ocp`` or ``~/.cache/gc_ocp``).
* ``CC`` — the C compiler (default ``gcc``, else ``cc``).

Without a working compiler (or an unwritable cache and temporary directory) the SX functions
are used, with one warning that says why and how to fix it.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import casadi as ca

log = logging.getLogger(__name__)

FLAGS = ("-O1", "-fPIC", "-shared")
"""-O1: 5.7x faster than the SX VM on the Hessian, compiled in ~17 s; -O2 gains 15 % more for
twice the compile time; -O0 compiles in 3 s but is only 2.9x faster (measured on a 2-core machine)."""


def compile_enabled() -> bool:
    return os.environ.get("GC_OCP_COMPILE", "1").strip().lower() not in ("0", "false", "no", "off")


def cache_dir() -> Path:
    d = os.environ.get("GC_OCP_CACHE_DIR")
    if d:
        return Path(d)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "gc_ocp"


def _compiler() -> str | None:
    cc = os.environ.get("CC")
    if cc:
        return shutil.which(cc)
    return shutil.which("gcc") or shutil.which("cc")


def _source(functions: list[ca.Function], name: str) -> str:
    with tempfile.TemporaryDirectory() as tmp:
        cg = ca.CodeGenerator(f"{name}.c", {"with_header": False})
        for f in functions:
            cg.add(f)
        cg.generate(tmp + os.sep)
        return Path(tmp, f"{name}.c").read_text()


def _build(src: str, cc: str, target: Path, say) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
        c_file = Path(tmp, "src.c")
        c_file.write_text(src)
        so = Path(tmp, target.name)
        say(
            f"compiling the per-frame contact functions to C with {Path(cc).name} {' '.join(FLAGS)} "
            f"(once per machine, ~10-20 s; cached in {target.parent})"
        )
        proc = subprocess.run(
            [cc, *FLAGS, str(c_file), "-o", str(so), "-lm"], capture_output=True, text=True
        )
        if proc.returncode != 0:
            raise RuntimeError(f"{cc} failed: {proc.stderr.strip()[-500:]}")
        os.replace(so, target)  # atomic: other processes see no file or the whole file


def _default_say(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def compiled(functions: list[ca.Function], name: str, say=None) -> list[ca.Function]:
    """C-compiled equivalents of ``functions`` (SX, distinct names), loaded from the cache or built
    into it; the originals when compiling is disabled or impossible (one warning)."""
    if not compile_enabled():
        return list(functions)
    say = say or _default_say
    cc = _compiler()
    if cc is None:
        warnings.warn(
            "No C compiler found (set CC, or install gcc): the estimator uses CasADi's "
            "slower SX virtual machine. Set GC_OCP_COMPILE=0 to silence this.",
            stacklevel=3,
        )
        return list(functions)
    src = _source(functions, name)
    key = hashlib.sha256(
        "\0".join([src, cc, *FLAGS, ca.__version__, sys.platform]).encode()
    ).hexdigest()[:16]
    errors = []
    for d in (
        cache_dir(),
        Path(tempfile.gettempdir()) / f"gc_ocp-{os.getuid() if hasattr(os, 'getuid') else 'u'}",
    ):
        target = d / f"{name}-{key}.so"
        try:
            if not target.exists():
                _build(src, cc, target, say)
            return [ca.external(f.name(), str(target)) for f in functions]
        except (OSError, RuntimeError) as e:
            errors.append(f"{d}: {e}")
    warnings.warn(
        "Could not compile the estimator's per-frame functions ("
        + "; ".join(errors)
        + "): using CasADi's slower SX virtual machine. Set GC_OCP_CACHE_DIR to a writable "
        "directory, or GC_OCP_COMPILE=0 to silence this.",
        stacklevel=3,
    )
    return list(functions)


__all__ = ["compiled", "compile_enabled", "cache_dir"]
