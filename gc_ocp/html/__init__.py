"""Self-contained HTML pages: what the diagnosis report, the fit report and a study's summary
page share (the jinja2 environment, the style, figures as ``data:`` URIs, the fit's tables).

Every page is one file with its CSS inline, its figures embedded as base64 PNG, no script and no
link to anything outside it: it can be mailed or archived as is. Templates live in
``gc_ocp/html/templates`` (``_style.html.j2`` is the shared style) and in the package of the
page that owns them (``gc_ocp/diagnosis/templates``).
"""

from __future__ import annotations

import base64
import datetime
import io

import jinja2

from gc_ocp.html.fit_tables import fmt_num, pm_value
from gc_ocp.values import BOUND_TEXT

FIGURE_DPI = 100


def environment(*packages: str) -> jinja2.Environment:
    """The jinja2 environment of a page whose templates are in ``<package>/templates`` (each
    of ``packages``, first match wins) and in ``gc_ocp/html/templates``; made per call (no
    module state). Autoescaping is on; ``num`` formats a number (:func:`fmt_num`: "–" when
    missing), ``fmt`` is :func:`format`; ``bound_text`` is
    :data:`~gc_ocp.values.BOUND_TEXT`."""
    loaders = [jinja2.PackageLoader(p, "templates") for p in (*packages, "gc_ocp.html")]
    env = jinja2.Environment(
        loader=jinja2.ChoiceLoader(loaders),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )
    env.filters["num"] = fmt_num
    env.filters["pm"] = pm_value  # value | pm(se): "value ± SE" as every table shows it
    env.filters["fmt"] = format
    env.globals["bound_text"] = BOUND_TEXT  # in place of a parameter's SE at its bound
    return env


def data_uri(png: bytes) -> str:
    """A PNG as a ``data:`` URI (embedded in the page)."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def pngs(figures: dict, dpi: int = FIGURE_DPI) -> dict[str, bytes]:
    """``{name: matplotlib figure}`` rendered as PNG bytes. The package's figures are
    :class:`~matplotlib.figure.Figure` objects pyplot does not hold: nothing to close, they go
    with their last reference."""
    out = {}
    for name, fig in figures.items():
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi)
        out[name] = buf.getvalue()
    return out


def provenance_context(prov: dict | None) -> dict:
    """A page's provenance section: the record written beside the output (``fit.json``'s or
    ``diagnosis.json``'s ``provenance``: inputs, options, date), or, without one, the version
    and the time of writing."""
    from gc_ocp import __version__

    if not prov:
        now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        return {"cli": False, "version": __version__, "now": now}
    trials = [
        {
            **t,
            "excluded": "; ".join(
                f"{e['side']} {e['t_on']:.2f}-{e['t_off']:.2f} s: {e['reason']}"
                for e in t.get("stances_excluded", [])
            ),
        }
        for t in prov.get("trials", [])
    ]
    opts = ", ".join(  # the options given: not None, False or [] (a 0 is given: 0 == False)
        f"{k}={v}"
        for k, v in prov.get("options", {}).items()
        if v is not None and v is not False and v != []
    )
    return {"cli": True, "record": prov, "trials": trials, "options": opts}


__all__ = ("FIGURE_DPI", "data_uri", "environment", "pngs", "provenance_context")
