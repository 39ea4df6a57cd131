"""Read the report's HTML back with the standard library (no lxml): tables by id, sections."""

from __future__ import annotations

import re
from html.parser import HTMLParser


class _Tables(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tables: dict[str, dict[str, list]] = {}
        self._id: str | None = None
        self._row: list[str] | None = None
        self._cell: list[str] | None = None
        self._in_head = False

    def handle_starttag(self, tag: str, attrs: list) -> None:
        a = dict(attrs)
        if tag == "table":
            self._id = a.get("id")
            self.tables[self._id] = {"columns": [], "rows": []}
        elif tag == "thead":
            self._in_head = True
        elif tag == "tr" and self._id:
            self._row = []
        elif tag in ("td", "th") and self._row is not None:
            self._cell = []

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None and self._row is not None:
            self._row.append("".join(self._cell).strip())
            self._cell = None
        elif tag == "tr" and self._row is not None and self._id:
            t = self.tables[self._id]
            (t["columns"] if self._in_head else t["rows"]).append(self._row)
            self._row = None
        elif tag == "thead":
            self._in_head = False
        elif tag == "table":
            self._id = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def read_tables(html: str) -> dict[str, dict[str, list]]:
    """``{table id: {"columns": [...], "rows": [[cell text, ...], ...]}}``."""
    p = _Tables()
    p.feed(html)
    return {k: {"columns": v["columns"][0] if v["columns"] else [], "rows": v["rows"]}
            for k, v in p.tables.items()}


def section(html: str, sid: str) -> str:
    """The HTML of ``<section id="sid">`` (empty if absent)."""
    m = re.search(rf'<section id="{re.escape(sid)}">(.*?)</section>', html, re.S)
    return m.group(1) if m else ""
