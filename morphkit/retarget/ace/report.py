"""Table-1-style reports: markdown and CSV of :class:`~morphkit.retarget.ace.evaluate.TableRow` rows."""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence
from pathlib import Path

from morphkit._atomic import atomic_write_text
from morphkit.retarget.ace.evaluate import TableRow

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
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    text = format_table(rows)
    atomic_write_text(stem.with_suffix(".md"), text + "\n")
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0].as_dict()), lineterminator="\n")
    writer.writeheader()
    writer.writerows(r.as_dict() for r in rows)
    atomic_write_text(stem.with_suffix(".csv"), buf.getvalue())
    return text
