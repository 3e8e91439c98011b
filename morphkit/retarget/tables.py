"""Result tables of the trainers' evaluations: one markdown file and one CSV file per table."""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from morphkit._atomic import atomic_write_text

__all__ = ["write_table_files"]


def write_table_files(stem: str | os.PathLike[str], markdown: str, records: Sequence[Mapping[str, Any]]) -> str:
    """Write ``stem.md`` (``markdown``) and ``stem.csv`` (one row per record), atomically; returns ``markdown``."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(stem.with_suffix(".md"), markdown + "\n")
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(records[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(records)
    atomic_write_text(stem.with_suffix(".csv"), buf.getvalue())
    return markdown
