"""The report of a comparison: Table 1 (markdown + CSV), bar charts, side-by-side videos and ``index.html``.

Layout of a report folder::

    index.html        the table, the charts and the videos on one page (relative links only)
    table.md/.csv     Table 1: the data set's row, then one row per method, mean ± std over its runs
    targets.md        the paper's claims checked on that table (:mod:`~morphkit.evaluation.targets`)
    runs.md/.csv      one row per run (seed, folder), with UFR split by effect
    evaluation.json   every number above, and the clips
    charts/*.png      one bar chart per metric (error bars: std over runs; dots: single runs)
    videos/*          per clip: human | each method (its first seed), labelled

A method trained with several seeds has one row per seed in ``runs`` and their mean and sample
standard deviation (ddof = 1) in ``table``.
"""

from __future__ import annotations

import html
import json
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from morphkit._atomic import atomic_path, atomic_write_text
from morphkit.evaluation.evaluate import Evaluation
from morphkit.evaluation.methods import method_order
from morphkit.evaluation.table import EXTRA_COLUMNS, PERCENT_FIGURES, TableRow
from morphkit.evaluation.targets import TargetCheck, check_targets, format_targets
from morphkit.output_names import unique_stems
from morphkit.retarget.tables import write_table_files

__all__ = [
    "CAUSES",
    "METRICS",
    "VIDEO_FPS",
    "SummaryRow",
    "format_extra",
    "format_summary",
    "mean_std",
    "plot_metrics",
    "render_videos",
    "summarize",
    "write_index",
    "write_report",
]

METRICS = (("div", "DIV", "→"), ("fid", "FID", "↓"), ("feature_loss", "L_fea", "↓"), ("ufr", "UFR", "↓"))
"""``(TableRow field, column name, better)`` of Table 1; DIV is best closest to the data set's."""
CAUSES = ("self_collision", "foot_penetration", "foot_sliding")
"""The effects UFR counts (:meth:`morphkit.metrics.UnrealisticFrames.cause_ratios`)."""
VIDEO_FPS = 15.0
"""Frame rate of the report's videos: half of the clips' 30 fps halves the rendering, the slow part of a
report (a 6-panel frame of 240 × 240 panels took ≈ 2 s on 2 shared CPU cores with shadows)."""


def mean_std(values: Sequence[float]) -> tuple[float, float]:
    """Mean and sample standard deviation (ddof = 1; 0 for a single value)."""
    a = np.asarray(values, dtype=float)
    return float(a.mean()), (float(a.std(ddof=1)) if a.size > 1 else 0.0)


@dataclass(frozen=True)
class SummaryRow:
    """One row of Table 1: a method's metrics as ``(mean, std)`` over its runs (``None``: does not apply)."""

    name: str
    seeds: tuple[int, ...]
    div: tuple[float, float]
    fid: tuple[float, float]
    feature_loss: tuple[float, float] | None
    ufr: tuple[float, float]
    frames: int
    """Frames scored per run."""
    values: dict[str, tuple[float, ...]]
    """Each metric's single-run values, by :data:`METRICS` field."""
    extra: dict[str, tuple[float, float] | None] = field(default_factory=dict)
    """The figures beyond the paper's (:data:`~morphkit.evaluation.table.EXTRA_COLUMNS`), ``(mean, std)``."""

    @property
    def runs(self) -> int:
        """Runs averaged in this row."""
        return max(len(self.seeds), 1)

    def as_dict(self) -> dict[str, object]:
        """The CSV record: each metric's mean and std."""
        out: dict[str, object] = {"method": self.name, "runs": self.runs,
                                  "seeds": " ".join(str(s) for s in self.seeds)}
        for key, column, _ in METRICS:
            value = getattr(self, key)
            out[column], out[f"{column}_std"] = (None, None) if value is None else value
        for key, column in EXTRA_COLUMNS:
            value = self.extra.get(key)
            out[column], out[f"{column}_std"] = (None, None) if value is None else value
        out["frames"] = self.frames
        return out


def summarize(dataset: TableRow, rows: Sequence[tuple[int, TableRow]]) -> list[SummaryRow]:
    """Table 1's rows: the data set's, then one per method name (mean ± std over its runs).

    Args:
        dataset: The data set's own row.
        rows: ``(seed, row)`` of every run; rows of one ``name`` are one method.
    """
    out = [SummaryRow(dataset.name, (), (dataset.div, 0.0), (dataset.fid, 0.0), None, (dataset.ufr, 0.0),
                      dataset.frames, {"div": (dataset.div,), "fid": (dataset.fid,), "ufr": (dataset.ufr,)},
                      _extra([dataset]))]
    for name in sorted({r.name for _, r in rows}, key=method_order):
        group = [(s, r) for s, r in rows if r.name == name]
        values = {key: tuple(float(getattr(r, key)) for _, r in group if getattr(r, key) is not None)
                  for key, _, _ in METRICS}
        out.append(SummaryRow(
            name, tuple(s for s, _ in group), mean_std(values["div"]), mean_std(values["fid"]),
            mean_std(values["feature_loss"]) if values["feature_loss"] else None, mean_std(values["ufr"]),
            int(group[0][1].frames), values, _extra([r for _, r in group])))
    return out


def _extra(rows: Sequence[TableRow]) -> dict[str, tuple[float, float] | None]:
    out: dict[str, tuple[float, float] | None] = {}
    for key, _ in EXTRA_COLUMNS:
        values = [float(getattr(r, key)) for r in rows if getattr(r, key) is not None]
        out[key] = mean_std(values) if values else None
    return out


PERCENT_COLUMNS = PERCENT_FIGURES | {"ufr"}
"""Figures shown as percentages."""


def _cell(value: tuple[float, float] | None, runs: int, *, percent: bool = False, digits: int = 3) -> str:
    if value is None:
        return "N/A"
    mean, std = value
    scale, unit = (100.0, "%") if percent else (1.0, "")
    text = f"{scale * mean:.{digits}f}{unit}"
    return f"{text} ± {scale * std:.{digits}f}{unit}" if runs > 1 else text


def format_summary(rows: Sequence[SummaryRow]) -> str:
    """Markdown: ``| method | runs | DIV → | FID ↓ | L_fea ↓ | UFR ↓ | frames |``, ``mean ± std`` over runs
    (the figures beyond the paper's: :func:`format_extra`)."""
    head = "| method | runs | " + " | ".join(f"{c} {b}" for _, c, b in METRICS) + " | frames |"
    lines = [head, "|---|---|" + "---|" * len(METRICS) + "---|"]
    for r in rows:
        cells = [_cell(getattr(r, key), r.runs, percent=key == "ufr") for key, _, _ in METRICS]
        lines.append(f"| {r.name} | {r.runs if r.seeds else '–'} | " + " | ".join(cells) + f" | {r.frames} |")
    return "\n".join(lines)


EXTRA_BETTER = {"fid_all": "↓", "div_all": "→", "follow": "↑", "follow_hand": "↑", "follow_reach": "↑",
                "follow_forward": "↑", "follow_yaw": "↑", "turn_gain": "→ 1"}
"""Which way is better for each extra figure (the rest: lower)."""


def format_extra(rows: Sequence[SummaryRow]) -> str:
    """Markdown: the figures beyond the paper's, one column each, ``mean ± std`` over runs."""
    head = "| method | " + " | ".join(f"{c} {EXTRA_BETTER.get(k, '↓')}" for k, c in EXTRA_COLUMNS) + " |"
    lines = [head, "|---|" + "---|" * len(EXTRA_COLUMNS)]
    for r in rows:
        cells = [_cell(r.extra.get(k), r.runs, percent=k in PERCENT_COLUMNS, digits=2 if k.endswith("_mm") else 3)
                 for k, _ in EXTRA_COLUMNS]
        lines.append(f"| {r.name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _run_records(evaluation: Evaluation) -> list[dict[str, object]]:
    records = [{"method": "Dataset", "seed": None, "stage": "", **{c: getattr(evaluation.dataset, k)
                for k, c, _ in METRICS}, **{c: getattr(evaluation.dataset, k) for k, c in EXTRA_COLUMNS},
                "frames": evaluation.dataset.frames, **evaluation.dataset_causes}]
    for res in evaluation.results:
        records.append({"method": res.method.name, "seed": res.method.seed, "stage": os.fspath(res.method.stage),
                        **{c: getattr(res.row, k) for k, c, _ in METRICS},
                        **{c: getattr(res.row, k) for k, c in EXTRA_COLUMNS}, "frames": res.row.frames, **res.causes})
    return records


def _format_runs(records: Sequence[dict[str, object]]) -> str:
    def num(v: object, percent: bool = False) -> str:
        return "N/A" if v is None else (f"{100 * float(v):.3f}%" if percent else f"{float(v):.3f}")  # type: ignore[arg-type]

    lines = ["| method | seed | DIV | FID | L_fea | UFR | self-collision | penetration | sliding | stage |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in records:
        seed = "–" if r["seed"] is None else r["seed"]
        lines.append(f"| {r['method']} | {seed} | {num(r['DIV'])} | {num(r['FID'])} | {num(r['L_fea'])} | "
                     f"{num(r['UFR'], True)} | " + " | ".join(num(r[c], True) for c in CAUSES) + f" | {r['stage']} |")
    return "\n".join(lines)


# ---- charts ---------------------------------------------------------------------------------------


def plot_metrics(rows: Sequence[SummaryRow], folder: str | os.PathLike[str], *, title: str = "") -> list[Path]:
    """One bar chart per metric (``folder/div.png`` …): bars at the mean, error bars at ±std, dots at
    single runs; DIV and UFR show the data set's value as a dashed line. Needs matplotlib.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    dataset, methods = rows[0], list(rows[1:])
    paths = []
    for key, column, better in METRICS:
        shown = [r for r in methods if getattr(r, key) is not None]
        scale = 100.0 if key == "ufr" else 1.0
        fig, ax = plt.subplots(figsize=(1.2 + 1.1 * max(len(shown), 1), 3.2), dpi=110)
        x = np.arange(len(shown))
        means = [scale * getattr(r, key)[0] for r in shown]
        stds = [scale * getattr(r, key)[1] for r in shown]
        ax.bar(x, means, yerr=stds, capsize=4, color="#4C72B0", alpha=0.85)
        for i, r in enumerate(shown):
            if r.runs > 1:
                ax.plot([i] * len(r.values[key]), [scale * v for v in r.values[key]], "k.", ms=4)
        if key in ("div", "ufr"):
            ax.axhline(scale * getattr(dataset, key)[0], color="#555555", ls="--", lw=1,
                       label=f"data set {scale * getattr(dataset, key)[0]:.3g}")
            ax.legend(fontsize=7, loc="best")
        ax.set_xticks(x, [r.name for r in shown], rotation=20, fontsize=8)
        ax.set_ylabel(f"{column}{' [%]' if key == 'ufr' else ''} {better}")
        ax.set_title(f"{title} {column}".strip(), fontsize=9)
        fig.tight_layout()
        path = folder / f"{column.lower()}.png"
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png")
        plt.close(fig)
        paths.append(path)
    return paths


# ---- videos ---------------------------------------------------------------------------------------


def render_videos(evaluation: Evaluation, folder: str | os.PathLike[str], *, count: int = 3,
                  suffix: str | None = None, size: tuple[int, int] = (240, 240), max_seconds: float = 8.0,
                  log: Callable[[str], None] = print) -> list[Path]:
    """Side-by-side videos of the first ``count`` clips: human | each method's first run, labelled.

    ``suffix`` ``.mp4`` (when ffmpeg is there; else ``.gif``) by default; ``.png`` writes a contact
    sheet of 12 synced frames instead. Clips are cut to ``max_seconds`` and shown at
    :data:`VIDEO_FPS`. An existing file is kept (a report re-run renders only what is missing).
    Without the render extra or an OpenGL platform it logs why and returns no paths.
    """
    try:
        from morphkit.render import RenderUnavailableError, ffmpeg_available, iter_side_by_side_frames, write_frames
    except ImportError as exc:  # the render extra is optional
        log(f"no videos: {exc} (pip install -e '.[render]')")
        return []
    suffix = suffix or (".mp4" if ffmpeg_available() else ".gif")
    first: dict[str, list] = {}
    for res in evaluation.results:
        first.setdefault(res.method.name, res.shown)
    names = sorted(first, key=method_order)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    # a clip's name (an NPZ's own name field) never steers the path; two names one stem stay two videos
    stems = unique_stems((clip.name for clip in evaluation.clips[:count]), default="clip")
    for i, clip in enumerate(evaluation.clips[:count]):
        panels = [clip] + [first[n][i] for n in names if i < len(first[n])]
        labels = ["human"] + [n for n in names if i < len(first[n])]
        frames = max(1, min(round(max_seconds * clip.fps), *(m.frame_count for m in panels)))
        panels = [m.slice(0, min(m.frame_count, frames)) for m in panels]
        fps = min(VIDEO_FPS, clip.fps)
        shown = max(1, math.ceil(frames / clip.fps * fps - 1e-9))  # output frames (as the renderer syncs them)
        path = folder / f"{stems[i]}{suffix}"
        if not path.is_file():
            indices = np.unique(np.linspace(0, shown - 1, 12).round().astype(int)) if suffix == ".png" else None
            try:
                write_frames(iter_side_by_side_frames(panels, labels=labels, size=size, fps=fps, frame_indices=indices,
                                                      progress=None), path, fps=fps)
            except RenderUnavailableError as exc:
                log(f"no videos: {exc}")
                return paths
        log(f"video: {path}")
        paths.append(path)
    return paths


# ---- page -----------------------------------------------------------------------------------------

_STYLE = """
body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1200px;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:4px 10px;text-align:right}
td:first-child,th:first-child{text-align:left}tr:first-child td{background:#f3f3f3}
.grid{display:flex;flex-wrap:wrap;gap:12px}.grid img{max-width:290px;border:1px solid #ddd}
video,.sheet{max-width:100%;border:1px solid #ddd}code{background:#f3f3f3;padding:0 3px}
"""


def _html_table(head: Sequence[str], body: Sequence[Sequence[str]]) -> str:
    th = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    rows = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>" for row in body)
    return f"<table><thead><tr>{th}</tr></thead><tbody>{rows}</tbody></table>"


def _link(path: Path, root: Path) -> str:
    return html.escape(Path(os.path.relpath(path, root)).as_posix(), quote=True)


def write_index(out: str | os.PathLike[str], evaluation: Evaluation, rows: Sequence[SummaryRow],
                charts: Sequence[Path], videos: Sequence[Path], *, notes: Sequence[str] = (),
                checks: Sequence[TargetCheck] | None = None) -> Path:
    """``out/index.html``: Table 1, the paper's claims (``checks``, default: checked on ``rows``), UFR by
    effect, the charts and the videos, with links relative to ``out``."""
    root = Path(out)
    checks = check_targets(rows, source_skating=evaluation.source_skating) if checks is None else checks
    ref = evaluation.reference
    frames = sum(c.frame_count for c in evaluation.clips)
    pairs = ", ".join(f"{c}→{h}" for c, h in ref.pairing.mapping.items())
    table = _html_table(
        ["method", "runs", *(f"{c} {b}" for _, c, b in METRICS), "frames"],
        [[r.name, str(r.runs) if r.seeds else "–",
          *(_cell(getattr(r, k), r.runs, percent=k == "ufr") for k, _, _ in METRICS), str(r.frames)] for r in rows])
    extra = _html_table(
        ["method", *(f"{c} {EXTRA_BETTER.get(k, '↓')}" for k, c in EXTRA_COLUMNS)],
        [[r.name, *(_cell(r.extra.get(k), r.runs, percent=k in PERCENT_COLUMNS, digits=2 if k.endswith("_mm") else 3)
                    for k, _ in EXTRA_COLUMNS)] for r in rows])
    records = _run_records(evaluation)
    causes = _html_table(
        ["method", "seed", "UFR", "self-collision", "foot penetration", "foot sliding", "stage"],
        [[str(r["method"]), "–" if r["seed"] is None else str(r["seed"]), f"{100 * float(r['UFR']):.3f}%",
          *(f"{100 * float(r[c]):.3f}%" for c in CAUSES), str(r["stage"])] for r in records])  # type: ignore[arg-type]
    parts = [
        "<!doctype html>", '<html lang="en"><head><meta charset="utf-8">',
        f"<title>morphkit evaluation: {html.escape(ref.creature.name)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>Retargeting human motion onto {html.escape(ref.creature.name)}</h1>",
        f"<p>{len(evaluation.clips)} held-out clips ({frames} frames, "
        f"{html.escape(ref.human_data or 'embedded default human motion')}), scored against "
        f"{sum(m.frame_count for m in ref.character)} frames of the creature's synthesised data set. "
        f"Ψ pairing: {html.escape(pairs)} "
        f"(from {html.escape(ref.source)}); body lengths {ref.pairing.creature_length:.3f} m (creature), "
        f"{ref.pairing.human_length:.3f} m (human).</p>",
        "<h2>Table 1</h2>", table,
        *(f"<p><b>FAILED</b> {html.escape(n)}: {html.escape(w)}</p>" for n, w in evaluation.failed.items()),
        "<p>DIV → : best closest to the data set's. FID, L_fea, UFR: lower is better. Mean ± sample std over "
        "runs (seeds) of a method. DIV and FID against the content-matched reference (the creature's data "
        "resampled to the clips' root speed and yaw rate); UFR strict: contact below 2 cm, sliding above "
        "0.2 m/s, penetration deeper than 5 mm, self-collision deeper than 5 mm. Definitions: "
        "<code>morphkit.metrics</code> (docs/guides/evaluate.md).</p>",
        "<h2>Beyond the paper: contact, reference and follow figures</h2>", extra,
        "<p>FID/DIV (all data): against the whole data set, as the paper. UFR medium: 5 cm / 0.5 m/s / 1 cm; "
        "loose: 5 cm / 1 m/s / 2 cm. sliding/foot, penetration/foot: per foot-frame. skating: GMD's ratio. "
        "Penetrate, Float, Skate: PhysDiff's, in mm. floating: frames in a flight longer than the data set's "
        "longest. follow: Pearson correlation of the human's and the creature's end-effector heights, forward "
        "velocity and yaw rate, per clip, averaged (1 follows exactly, 0 unrelated). turn gain: the creature's "
        "yaw rate regressed on the human's, every clip's frames together (1 turns through the human's angle, 0 "
        "does not turn). drift: how fast the creature goes where the human does not, per clip, averaged (body "
        "lengths/s; e.g. walking backwards while the human stands).</p>",
        '<p>Files: <a href="table.md">table.md</a>, <a href="table.csv">table.csv</a>, '
        '<a href="runs.csv">runs.csv</a>, <a href="evaluation.json">evaluation.json</a></p>',
        "<h2>The paper's claims</h2>",
        _html_table(["claim", "met", "measured"], [[c.claim, c.mark, c.detail] for c in checks]),
        "<h2>Charts</h2>", '<div class="grid">',
        *(f'<a href="{_link(p, root)}"><img src="{_link(p, root)}" alt="{html.escape(p.stem)}"></a>' for p in charts),
        "</div>", "<h2>Unrealistic frames by effect, per run</h2>", causes, "<h2>Videos</h2>",
    ]
    if not videos:
        parts.append("<p>No videos in this report.</p>")
    for v in videos:
        parts.append(f"<h3>{html.escape(v.stem)}</h3>")
        if v.suffix.lower() in (".mp4", ".webm"):
            parts.append(f'<video src="{_link(v, root)}" controls loop muted playsinline></video>')
        else:
            parts.append(f'<img class="sheet" src="{_link(v, root)}" alt="{html.escape(v.stem)}">')
    parts += [f"<p>{html.escape(n)}</p>" for n in notes]
    parts.append("</body></html>")
    path = root / "index.html"
    atomic_write_text(path, "\n".join(parts) + "\n")
    return path


def write_report(
    evaluation: Evaluation,
    out: str | os.PathLike[str],
    *,
    videos: int = 3,
    video_suffix: str | None = None,
    video_size: tuple[int, int] = (240, 240),
    video_seconds: float = 8.0,
    log: Callable[[str], None] = print,
) -> str:
    """Write the report folder (see the module docs); returns Table 1's markdown."""
    root = Path(out)
    root.mkdir(parents=True, exist_ok=True)
    rows = summarize(evaluation.dataset, [(r.method.seed, r.row) for r in evaluation.results])
    failures = "".join(f"\n\nFAILED {name}: {why}" for name, why in evaluation.failed.items())
    markdown = write_table_files(root / "table", format_summary(rows) + "\n\n" + format_extra(rows) + failures,
                                 [r.as_dict() for r in rows])
    checks = check_targets(rows, source_skating=evaluation.source_skating)
    atomic_write_text(root / "targets.md", format_targets(checks) + "\n")
    records = _run_records(evaluation)
    write_table_files(root / "runs", _format_runs(records), records)
    ref = evaluation.reference
    summary = {
        "creature": ref.creature.name, "human_data": ref.human_data, "reference": ref.source,
        "mapping": ref.pairing.mapping, "creature_length": ref.pairing.creature_length,
        "human_length": ref.pairing.human_length, "character_frames": sum(m.frame_count for m in ref.character),
        "clips": {c.name: c.frame_count for c in evaluation.clips},
        "table": [r.as_dict() for r in rows], "runs": records,
        "targets": [{"claim": c.claim, "met": c.met, "measured": c.detail} for c in checks],
        "failed": dict(evaluation.failed), "source_skating": evaluation.source_skating,
    }
    atomic_write_text(root / "evaluation.json", json.dumps(summary, indent=1) + "\n")
    notes: list[str] = []
    try:
        charts = plot_metrics(rows, root / "charts", title=ref.creature.name)
    except ImportError as exc:
        charts = []
        notes.append(f"No charts: {exc} (pip install matplotlib).")
        log(notes[-1])
    shown = render_videos(evaluation, root / "videos", count=videos, suffix=video_suffix, size=video_size,
                          max_seconds=video_seconds, log=log) if videos > 0 else []
    page = write_index(root, evaluation, rows, charts, shown, notes=notes, checks=checks)
    log(f"report: {page}")
    return markdown
