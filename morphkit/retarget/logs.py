"""Metrics logs of a run: ``metrics.csv`` (one row per :meth:`MetricsLog.write`) and TensorBoard events.

The CSV has one header line and is appended to. On resume the rows written after the
checkpoint are dropped (:class:`MetricsLog` keeps the first ``keep_rows``), and TensorBoard's
``purge_step`` drops the events past the checkpoint's step, so neither shows the lost steps twice.
A new metric name appearing mid-run rewrites the file once with the wider header (earlier rows
leave it empty).
"""

from __future__ import annotations

import csv
import io
import math
import os
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from morphkit._atomic import atomic_write_text

__all__ = ["METRICS_CSV", "TENSORBOARD_DIR", "MetricsLog", "read_metrics"]

METRICS_CSV = "metrics.csv"
"""File name of the metrics table in a run folder."""
TENSORBOARD_DIR = "tensorboard"
"""Folder of the TensorBoard event files in a run folder."""


class MetricsLog:
    """Append-only metrics table plus TensorBoard scalars for one run folder.

    Args:
        run_dir: The run folder.
        keep_rows: Rows of an existing ``metrics.csv`` to keep (those the checkpoint saw);
            ``None`` keeps them all.
        purge_step: Global step from which earlier TensorBoard events are discarded (resume).
        tensorboard: Also write TensorBoard event files.
        enabled: ``False`` on ranks other than 0: nothing is read or written.
    """

    def __init__(
        self,
        run_dir: str | os.PathLike[str],
        *,
        keep_rows: int | None = None,
        purge_step: int | None = None,
        tensorboard: bool = True,
        enabled: bool = True,
    ) -> None:
        self.path = Path(run_dir) / METRICS_CSV
        self.enabled = enabled
        self.columns: list[str] = []
        self.rows = 0
        """Data rows in the CSV (what a checkpoint records as ``keep_rows``)."""
        self._file: io.TextIOWrapper | None = None
        self._writer: Any = None
        self._tb: Any = None
        if not enabled:
            return
        if self.path.exists() and self.path.stat().st_size == 0:
            self.path.unlink()
        if self.path.exists():
            columns, rows = read_metrics(self.path, raw=True)
            cut = not self.path.read_bytes().endswith(b"\n")  # a row half-written by a kill
            if cut or (keep_rows is not None and len(rows) > keep_rows):
                rows = rows if keep_rows is None else rows[:keep_rows]
                self._rewrite(columns, rows)
            self.columns, self.rows = columns, len(rows)
        if self.columns:
            self._open()
        self._tb = _summary_writer(Path(run_dir) / TENSORBOARD_DIR, purge_step) if tensorboard else None

    def write(self, values: Mapping[str, Any]) -> None:
        """Append one row (numbers or 0-d tensors; missing columns stay empty); also to TensorBoard.

        The ``global_step`` value, when present, is the TensorBoard step.
        """
        if not self.enabled:
            return
        row = {k: _number(v) for k, v in values.items()}
        new = [k for k in row if k not in self.columns]
        if new:
            _, rows = read_metrics(self.path, raw=True) if self.path.exists() else ([], [])
            self.columns = self.columns + new
            self.close_file()
            self._rewrite(self.columns, rows)
            self._open()
        self._writer.writerow({k: "" if v is None else repr(v) for k, v in row.items()})
        self._file.flush()  # type: ignore[union-attr]
        self.rows += 1
        if self._tb is not None:
            step = int(row["global_step"]) if row.get("global_step") is not None else self.rows
            for key, value in row.items():
                if key not in ("epoch", "step", "global_step") and value is not None and math.isfinite(value):
                    self._tb.add_scalar(key, value, step)

    def flush(self) -> None:
        """Push buffered TensorBoard events to disk (the CSV is flushed on every row)."""
        if self._tb is not None:
            self._tb.flush()

    def close(self) -> None:
        """Close the CSV and the TensorBoard writer."""
        self.close_file()
        if self._tb is not None:
            self._tb.close()
            self._tb = None

    def close_file(self) -> None:
        """Close the CSV handle (reopened on the next write)."""
        if self._file is not None:
            self._file.close()
            self._file, self._writer = None, None

    def _open(self) -> None:
        fresh = not self.path.exists() or self.path.stat().st_size == 0
        self._file = open(self.path, "a", newline="", encoding="utf-8")
        self._writer = csv.DictWriter(self._file, fieldnames=self.columns)
        if fresh:
            self._writer.writeheader()
            self._file.flush()

    def _rewrite(self, columns: list[str], rows: list[dict[str, str]]) -> None:
        buffer = io.StringIO()
        writer = csv.DictWriter(buffer, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
        atomic_write_text(self.path, buffer.getvalue())


def read_metrics(path: str | os.PathLike[str], *, raw: bool = False) -> tuple[list[str], list[dict[str, Any]]]:
    """The columns and rows of a ``metrics.csv``; values as floats (``None`` where empty) unless ``raw``.

    A last line cut short by a kill is dropped.
    """
    text = Path(path).read_text(encoding="utf-8")
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]
    reader = csv.DictReader(io.StringIO(text))
    columns = list(reader.fieldnames or [])
    rows = [dict(r) for r in reader]
    if not raw:
        rows = [{k: float(v) if v not in ("", None) else None for k, v in r.items()} for r in rows]
    return columns, rows


def _number(value: Any) -> float | int | None:
    if value is None:
        return None
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, bool):
        return int(value)
    return value if isinstance(value, int) else float(value)


def _summary_writer(log_dir: Path, purge_step: int | None) -> Any:
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:  # pragma: no cover - tensorboard is a dependency; a broken install only loses the events
        warnings.warn("tensorboard is not installed: no event files are written", stacklevel=3)
        return None
    return SummaryWriter(log_dir=str(log_dir), purge_step=purge_step)
