"""Table-1-style reports: markdown and CSV of :class:`~morphkit.retarget.ace.evaluate.TableRow` rows."""

from __future__ import annotations

import os
from collections.abc import Sequence

from morphkit.retarget.ace.evaluate import TableRow
from morphkit.retarget.tables import write_table_files

__all__ = ["format_table", "write_table"]


def _cell(value: float | None, digits: int = 3, percent: bool = False) -> str:
    if value is None:
        return "N/A"
    return f"{100 * value:.{digits}f}%" if percent else f"{value:.{digits}f}"


def format_table(rows: Sequence[TableRow]) -> str:
    """Markdown: ``| method | DIV → | FID ↓ | L_fea ↓ | UFR ↓ | frames |`` (DIV: closest to the data set's)."""
    lines = ["| method | DIV → | FID ↓ | L_fea ↓ | UFR ↓ | frames |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r.name} | {_cell(r.div)} | {_cell(r.fid)} | {_cell(r.feature_loss)} | "
                     f"{_cell(r.ufr, percent=True)} | {r.frames} |")
    return "\n".join(lines)


def write_table(rows: Sequence[TableRow], stem: str | os.PathLike[str]) -> str:
    """Write ``stem.md`` and ``stem.csv`` (atomically); returns the markdown."""
    return write_table_files(stem, format_table(rows), [r.as_dict() for r in rows])
