"""The report's words for a study that leads with another response than the angle.

The stage sections, their tables and figures are written for the angle of repose (``AoR
(deg)``, ``AoR (°)``, "AoR over the scan"). A study may lead with any response its test
reports (:mod:`demcal.calibrate.responses`); for it, every table, figure and stage section
passes through :func:`relabel` here, in one place, so its lead's name and unit stand where the
angle's would. For a study of the angle nothing changes (byte for byte).
"""

from __future__ import annotations

import re

from matplotlib.figure import Figure
from matplotlib.text import Text

from demcal.report.data import Lead
from demcal.report.tables import Table

__all__ = ["relabel", "relabel_figure", "relabel_html", "relabel_table"]

#: an embedded figure in the page: its base64 text is data, never words to change
_EMBEDDED = re.compile(r"(data:image/png;base64,[A-Za-z0-9+/=]+)")


def relabel(text: str, lead: Lead) -> str:
    """``text`` with the angle's words replaced by the lead's name and unit."""
    if lead.is_angle or not text:
        return text
    unit = lead.unit
    with_unit = f"{lead.name} ({unit})" if unit else lead.name
    out = text.replace("AoR (deg)", with_unit).replace("AoR (°)", with_unit)
    out = out.replace("(deg)", f"({unit})" if unit else "").replace("(°)", f"({unit})"
                                                                     if unit else "")
    out = out.replace("AoR", lead.name)
    out = re.sub(r"(\d)°", rf"\1 {unit}" if unit else r"\1", out)
    return out.replace("°", unit)


def relabel_table(table: Table, lead: Lead) -> Table:
    """The table with the lead's words in its title, note and column names."""
    if lead.is_angle:
        return table
    frame = table.frame.rename(columns={c: relabel(str(c), lead) for c in table.frame.columns})
    return Table(table.key, relabel(table.title, lead), frame,
                 note=relabel(table.note, lead))


def relabel_figure(fig: Figure, lead: Lead) -> Figure:
    """The figure with the lead's words in every text it draws (titles, axes, legends,
    colour bars)."""
    if not lead.is_angle:
        for text in fig.findobj(Text):
            words = text.get_text()
            if words:
                text.set_text(relabel(words, lead))
    return fig


def relabel_html(html: str, lead: Lead) -> str:
    """A stage section's HTML with the lead's words, its embedded figures left as they are."""
    if lead.is_angle:
        return html
    parts = _EMBEDDED.split(html)
    return "".join(p if _EMBEDDED.fullmatch(p) else relabel(p, lead) for p in parts)
