"""HTML pieces of the report: tables, embedded figures, stage banners and the page.

The page is self-contained: inline CSS, PNG figures as base64 ``data:`` URIs, no scripts and
no fonts or files fetched from anywhere; a print stylesheet keeps tables and figures whole.
"""

from __future__ import annotations

import base64
from html import escape

from demcal.report.data import StageView
from demcal.report.tables import Table, format_cell

__all__ = ["CSS", "banner", "figure_html", "page", "table_html"]

CSS = """
:root { --ink:#1d2430; --muted:#5b6472; --line:#d5d9e0; --accent:#1f5fa8; }
* { box-sizing: border-box; }
body { font-family: "DejaVu Sans", "Helvetica Neue", Arial, sans-serif; color: var(--ink);
       margin: 0 auto; max-width: 1100px; padding: 24px 32px; line-height: 1.45;
       font-size: 14px; background: #fff; }
h1 { font-size: 24px; margin: 0 0 4px; }
h2 { font-size: 19px; margin: 32px 0 8px; padding-bottom: 4px;
     border-bottom: 2px solid var(--accent); }
h3 { font-size: 15px; margin: 18px 0 6px; }
p.meta, .note, figcaption { color: var(--muted); font-size: 12.5px; }
.summary { display: grid; grid-template-columns: repeat(auto-fit, minmax(200px, 1fr));
           gap: 10px; margin: 14px 0; }
.card { border: 1px solid var(--line); border-radius: 6px; padding: 8px 12px; }
.card .k { color: var(--muted); font-size: 12px; }
.card .v { font-size: 18px; font-weight: 600; }
.tablewrap { overflow-x: auto; margin: 6px 0 12px; }
table.data { border-collapse: collapse; font-size: 12.5px; min-width: 30%; }
table.data caption { text-align: left; font-weight: 600; padding: 4px 0; caption-side: top; }
table.data th, table.data td { border-bottom: 1px solid var(--line); padding: 3px 9px;
                              vertical-align: top; }
table.data th, table.data td.num { white-space: nowrap; }
table.data td { max-width: 520px; overflow-wrap: anywhere; }
.row { display: flex; flex-wrap: wrap; gap: 0 28px; align-items: flex-start; }
table.data th { background: #eef2f7; text-align: left; }
table.data td.num { text-align: right; font-variant-numeric: tabular-nums; }
table.data tr:nth-child(even) td { background: #fafbfc; }
figure { margin: 10px 0 16px; text-align: center; }
figure img { max-width: 100%; height: auto; border: 1px solid var(--line); }
.gallery { display: grid; grid-template-columns: repeat(auto-fill, minmax(220px, 1fr));
           gap: 8px; }
.gallery figure { margin: 4px 0; }
details > summary { cursor: pointer; color: var(--muted); font-size: 12.5px; }
figure.pair { display: flex; gap: 12px; flex-wrap: wrap; justify-content: center; }
figure.pair > div { flex: 1 1 300px; }
code, .eq { font-family: "DejaVu Sans Mono", Consolas, monospace; font-size: 12.5px; }
.eq { background: #f5f7fa; border: 1px solid var(--line); border-radius: 4px; padding: 6px 10px;
      white-space: pre-wrap; word-break: break-word; }
.status { display: inline-block; padding: 1px 8px; border-radius: 10px; font-size: 12px;
          font-weight: 600; vertical-align: middle; margin-left: 6px; }
.status.done { background: #dff3e3; color: #1c6b2f; }
.status.failed { background: #fbe0e0; color: #9b1c1c; }
.status.running { background: #fff2cc; color: #7a5b00; }
.status.missing, .status.disabled { background: #eceef1; color: #5b6472; }
.banner { border-left: 4px solid; padding: 6px 12px; margin: 8px 0; border-radius: 3px; }
.banner.failed { border-color: #c62828; background: #fdf1f1; }
.banner.missing { border-color: #8a93a0; background: #f4f5f7; }
.banner.running { border-color: #d4a100; background: #fffaeb; }
.warn { color: #8a5a00; }
p.verdict { background: #f5f7fa; border-left: 4px solid var(--accent); padding: 4px 10px; }
@media (max-width: 640px) {
  body { padding: 10px 10px; font-size: 13px; }
  h1 { font-size: 20px; }
  h2 { font-size: 17px; }
  .summary { grid-template-columns: repeat(2, minmax(0, 1fr)); gap: 6px; }
  .card .v { font-size: 15px; }
  .row { display: block; }
  table.data { font-size: 11.5px; }
  table.data td { max-width: 70vw; overflow-wrap: normal; min-width: 3.5em; }
  .gallery { grid-template-columns: repeat(2, minmax(0, 1fr)); }
}
@media print {
  body { max-width: none; padding: 0; font-size: 11px; }
  figure img { max-height: 24cm; object-fit: contain; }
  details > *:not(summary) { display: block; }
  h2, h3 { page-break-after: avoid; break-after: avoid-page; }
  figure, .tablewrap, table.data, .card { page-break-inside: avoid; break-inside: avoid; }
  .tablewrap { overflow: visible; }
  section { page-break-before: auto; }
}
"""


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def table_html(table: Table) -> str:
    """``<table class="data" id="t-KEY">`` with a caption, header and formatted cells."""
    frame = table.frame
    head = "".join(f"<th>{escape(str(c))}</th>" for c in frame.columns)
    body = []
    for row in frame.itertuples(index=False):
        cells = []
        for col, v in zip(frame.columns, row, strict=True):
            cls = ' class="num"' if _is_number(v) else ""
            cells.append(f"<td{cls}>{escape(format_cell(v, str(col)))}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    if not body:
        body.append(f'<tr><td colspan="{max(len(frame.columns), 1)}">(no rows)</td></tr>')
    note = f'<p class="note">{escape(table.note)}</p>' if table.note else ""
    return (f'<div class="tablewrap"><table class="data" id="t-{escape(table.key)}">'
            f"<caption>{escape(table.title)}</caption><thead><tr>{head}</tr></thead>"
            f"<tbody>{''.join(body)}</tbody></table>{note}</div>")


def figure_html(png: bytes, caption: str, alt: str = "") -> str:
    """A figure with the PNG embedded as a base64 data URI."""
    data = base64.b64encode(png).decode("ascii")
    return (f'<figure><img alt="{escape(alt or caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{escape(caption)}</figcaption></figure>")


def banner(view: StageView) -> str:
    """Status badge and, unless done, a banner saying what failed or is missing."""
    if view.status == "failed":
        return f'<div class="banner failed"><b>Stage failed:</b> {escape(view.error or "")}</div>'
    if view.status == "missing" and view.runs:
        return ('<div class="banner missing"><b>Not run:</b> the store has no summary of this '
                "stage, only the runs listed below (left from an earlier attempt).</div>")
    if view.status == "missing":
        return ('<div class="banner missing"><b>Not run:</b> the store has no record of this '
                "stage.</div>")
    if view.status == "disabled":
        return ('<div class="banner missing"><b>Disabled:</b> the study turns this stage '
                "off.</div>")
    if view.status == "running":
        return ('<div class="banner running"><b>In progress:</b> this stage had not finished '
                "when the report was built; what is shown is partial.</div>")
    return ""


def badge(status: str) -> str:
    """A small coloured status label."""
    return f'<span class="status {escape(status)}">{escape(status)}</span>'


def page(title: str, body: str) -> str:
    """The whole HTML document (inline CSS, nothing external)."""
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{escape(title)}</title>"
            '<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<style>{CSS}</style></head><body>{body}</body></html>\n")
