"""The report as a document: sections of paragraphs, tables and figures, rendered as Markdown
and as self-contained HTML (figures inline), so the two renderings never disagree."""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from .tables import format_cell


@dataclass
class Table:
    """Rows of a table and its columns: (row key, title with unit, format spec of the cell)."""

    columns: Sequence[tuple[str, str, str]]  # (key, title with unit, format spec)
    rows: Sequence[dict[str, Any]]


@dataclass
class Section:
    """A titled part of the document: str paragraphs, :class:`Table`, or Path (a PNG figure)."""

    title: str
    parts: list[Any] = field(default_factory=list)  # str paragraphs, Table, or Path (figure)


def to_markdown(sections: Sequence[Section], title: str, base: Path) -> str:
    """The document as Markdown; figures are linked relative to ``base``."""
    out = [f"# {title}", ""]
    for sec in sections:
        out += [f"## {sec.title}", ""]
        for part in sec.parts:
            if isinstance(part, str):
                out += [part, ""]
            elif isinstance(part, Table):
                out.append("| " + " | ".join(t for _, t, _ in part.columns) + " |")
                out.append("|" + "---|" * len(part.columns))
                for r in part.rows:
                    out.append("| " + " | ".join(format_cell(r.get(k), f) for k, _, f in part.columns) + " |")
                out.append("")
            elif isinstance(part, Path):
                out += [f"![{part.stem}]({part.relative_to(base).as_posix()})", ""]
    return "\n".join(out)


def to_html(sections: Sequence[Section], title: str) -> str:
    """The document as one HTML page with its figures inline (base64 PNG)."""
    css = ("body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}"
           "table{border-collapse:collapse;font-size:12px;margin:0.5em 0 1.5em}"
           "td,th{border:1px solid #bbb;padding:2px 6px;text-align:right}th{background:#eee}"
           "td:first-child,th:first-child{text-align:left}img{max-width:100%}")
    out = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>",
           f"<style>{css}</style></head><body><h1>{html.escape(title)}</h1>"]
    for sec in sections:
        out.append(f"<h2>{html.escape(sec.title)}</h2>")
        for part in sec.parts:
            if isinstance(part, str):
                out.append(f"<p>{html.escape(part)}</p>")
            elif isinstance(part, Table):
                out.append("<table><tr>" + "".join(f"<th>{html.escape(t)}</th>" for _, t, _ in part.columns) + "</tr>")
                for r in part.rows:
                    out.append("<tr>" + "".join(f"<td>{html.escape(format_cell(r.get(k), f))}</td>" for k, _, f in part.columns) + "</tr>")
                out.append("</table>")
            elif isinstance(part, Path) and part.exists():
                data = base64.b64encode(part.read_bytes()).decode()
                out.append(f"<p><img alt='{html.escape(part.stem)}' src='data:image/png;base64,{data}'></p>")
    out.append("</body></html>")
    return "\n".join(out)
