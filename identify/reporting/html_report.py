"""A self-contained HTML report a lab can hand on: a header that says what was analysed
(specimen, the spec and measurement files with their SHA-256, date, tool version), the
sections of the text report as tables, and the figures embedded (base64 PNG), so one
file opens in any browser without a server or the files beside it."""

from __future__ import annotations

import base64
import hashlib
import html
import sys
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

from fem.io import tool_version

from .rounding import status_line

if TYPE_CHECKING:  # annotations only: a data frame is handed in
    import pandas as pd

STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto; max-width: 70em;
       color: #1a1a1a; line-height: 1.4; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; } h2 { font-size: 1.15em; margin-top: 1.6em;
       border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: right; }
th { background: #f2f2f2; } td:first-child, th:first-child { text-align: left; }
.status { padding: 0.6em 1em; border-radius: 4px; margin: 1em 0; }
.converged { background: #e6f4ea; border: 1px solid #34a853; }
.warning { background: #fef7e0; border: 1px solid #f9ab00; }
.header td { text-align: left; } img { max-width: 100%; margin: 0.5em 0; }
ul.notes li { margin: 0.3em 0; } .small { color: #555; font-size: 0.85em; }
"""

#: The page's rules a notebook view needs (tables and the status box), scoped to the view.
VIEW_STYLE = """
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: right; }
th { background: #f2f2f2; }
.status { padding: 0.6em 1em; border-radius: 4px; margin: 1em 0; }
.converged { background: #e6f4ea; border: 1px solid #34a853; }
.warning { background: #fef7e0; border: 1px solid #f9ab00; }
"""


def file_digest(path: str | Path) -> str:
    """SHA-256 of a file (hex), or '' when it is not a readable file (bundled or built
    in code)."""
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return ""


def provenance(title: str, specimen: str, spec: str, measurements: str | None) -> dict[str, str]:
    """The header rows: what was analysed, from which files, when, with what."""
    rows = {"analysis": title, "specimen": specimen}
    for name, path in (("spec file", spec), ("measurement file", measurements)):
        if path:
            digest = file_digest(path)
            rows[name] = f"{path}" + (f" (SHA-256 {digest})" if digest else "")
    rows["date"] = datetime.now(UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
    rows["tool"] = f"layer-id {tool_version()} (Python {sys.version.split()[0]})"
    rows["command"] = " ".join(Path(sys.argv[0]).name.split() + sys.argv[1:]) if sys.argv else ""
    return rows


def blank_missing(frame: pd.DataFrame, blank: str = "") -> pd.DataFrame:
    """``frame`` with the None and NaN of its object (mixed) columns shown as ``blank``;
    float columns keep NaN for the writer's own ``na_rep``."""
    out = frame.copy()
    for column in out.columns[out.dtypes == object]:
        out[column] = out[column].map(
            lambda v: blank if v is None or (isinstance(v, float) and v != v) else v
        )
    return out


def table(frame: pd.DataFrame, float_format: str = "{:.6g}") -> str:
    """A data frame as an HTML table (numbers formatted, text escaped, a value that does
    not exist (NaN, None) a blank cell)."""
    return blank_missing(frame).to_html(
        index=False, escape=True, na_rep="", border=0, float_format=lambda x: float_format.format(x)
    )


def figure(path: str | Path, caption: str) -> str:
    """A PNG embedded as a data URI, with its caption."""
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    return (
        f'<figure><img src="data:image/png;base64,{data}" alt="{html.escape(caption)}">'
        f'<figcaption class="small">{html.escape(caption)}</figcaption></figure>'
    )


def notes(items) -> str:
    items = list(items)
    return (
        '<ul class="notes">' + "".join(f"<li>{html.escape(str(i))}</li>" for i in items) + "</ul>"
        if items
        else "<p>none</p>"
    )


def document(
    title: str, header: dict[str, str], status: tuple[str, bool] | None, sections: list[tuple[str, str]]
) -> str:
    """The whole page: title, header table, a status box (one status line, good?), then
    (heading, html) sections."""
    rows = "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in header.items())
    parts = [
        f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>'
        f"<style>{STYLE}</style></head><body><h1>{html.escape(title)}</h1>",
        f'<table class="header">{rows}</table>',
    ]
    if status is not None:
        parts.append(status_box(*status))
    parts += [f"<h2>{html.escape(heading)}</h2>{body}" for heading, body in sections]
    parts.append("</body></html>")
    return "\n".join(parts)


def status_box(name: str, message: str, good: bool) -> str:
    """How an analysis ended, green when it may be used as it stands, amber otherwise: one
    status line (the status not repeated when the message starts with it)."""
    head, colon, rest = status_line(name, message).partition(": ")
    return (
        f'<div class="status {"converged" if good else "warning"}"><strong>{html.escape(head)}</strong>'
        f"{colon}{html.escape(rest)}</div>"
    )


def paragraph(text: str) -> str:
    return f"<p>{html.escape(text)}</p>"


def view(title: str, status: tuple[str, str, bool] | None, sections: list[tuple[str, str]]) -> str:
    """A notebook view (``_repr_html_``): the same status box and section tables as the
    report page, in a block styled only inside itself."""
    scoped = "\n".join(f".layer-id {rule}" for rule in VIEW_STYLE.strip().splitlines())
    parts = [f'<div class="layer-id"><style>{scoped}</style><h3>{html.escape(title)}</h3>']
    if status is not None:
        parts.append(status_box(*status))
    parts += [f"<h4>{html.escape(heading)}</h4>{body}" for heading, body in sections]
    parts.append("</div>")
    return "\n".join(parts)


__all__ = [
    "provenance",
    "table",
    "figure",
    "notes",
    "document",
    "file_digest",
    "status_box",
    "paragraph",
    "view",
]
