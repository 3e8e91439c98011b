"""Still images: labels drawn on frames, contact sheets (PNG grids), atomic image writes."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from morphkit._atomic import atomic_path
from morphkit.errors import ConfigError

__all__ = ["contact_sheet", "draw_label", "sample_indices", "write_image"]


def _font(size: int):  # -> PIL.ImageFont.ImageFont | FreeTypeFont
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except (TypeError, OSError):  # Pillow < 10.1 or no FreeType: the fixed bitmap font
        return ImageFont.load_default()


def draw_label(image: np.ndarray, text: str, *, bottom: bool = False, size: int | None = None) -> np.ndarray:
    """A copy of ``image`` (RGB uint8 [H, W, 3]) with ``text`` on a translucent box in its top-left
    corner (bottom-left with ``bottom=True``); ``size`` is the font size [px], about H/24 by default."""
    from PIL import Image, ImageDraw

    h = image.shape[0]
    font = _font(size or max(12, h // 24))
    img = Image.fromarray(np.ascontiguousarray(image[..., :3])).convert("RGBA")
    overlay = Image.new("RGBA", img.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(overlay)
    margin = max(4, h // 60)
    _, top, _, bottom_ = draw.textbbox((0, 0), text, font=font)
    xy = (margin, h - margin - bottom_) if bottom else (margin, margin - top)
    left, top, right, bottom_ = draw.textbbox(xy, text, font=font)
    pad = max(2, (bottom_ - top) // 4)
    draw.rectangle((left - pad, top - pad, right + pad, bottom_ + pad), fill=(255, 255, 255, 190))
    draw.text(xy, text, font=font, fill=(20, 20, 20, 255))
    return np.asarray(Image.alpha_composite(img, overlay).convert("RGB"))


def sample_indices(n: int, count: int) -> np.ndarray:
    """``min(n, count)`` frame indices spread evenly over ``[0, n)``, first frame included."""
    if n <= count:
        return np.arange(n)
    return np.floor(np.arange(count) * n / count).astype(int)


def contact_sheet(
    frames: Sequence[np.ndarray] | np.ndarray,
    *,
    columns: int | None = None,
    labels: Sequence[str] | None = None,
    tile_width: int | None = None,
    pad: int = 6,
) -> np.ndarray:
    """Lay frames out in a grid, row by row, on a white background.

    Args:
        frames: Equally sized RGB uint8 images [H, W, 3].
        columns: Tiles per row; about square overall when omitted.
        labels: One caption per frame, drawn in each tile's bottom-left corner.
        tile_width: Width each tile is scaled to [px] (aspect kept); unscaled when omitted.
        pad: Gap between tiles and around the border [px].

    Returns:
        The sheet, RGB uint8 [rows·h + pad·(rows+1), columns·w + pad·(columns+1), 3].
    """
    from PIL import Image

    frames = [np.asarray(f)[..., :3] for f in frames]
    if not frames:
        raise ConfigError("a contact sheet needs at least one frame")
    if labels is not None and len(labels) != len(frames):
        raise ConfigError(f"contact sheet: {len(labels)} labels for {len(frames)} frames")
    h, w = frames[0].shape[:2]
    if any(f.shape[:2] != (h, w) for f in frames):
        raise ConfigError("contact sheet: frames must all have the same size")
    if tile_width is not None and tile_width != w:
        th = max(1, round(h * tile_width / w))
        frames = [np.asarray(Image.fromarray(f).resize((tile_width, th), Image.LANCZOS)) for f in frames]
        h, w = th, tile_width
    n = len(frames)
    cols = columns or max(1, round(math.sqrt(n * h / w)))
    cols = min(cols, n)
    rows = math.ceil(n / cols)
    sheet = np.full((rows * h + pad * (rows + 1), cols * w + pad * (cols + 1), 3), 255, dtype=np.uint8)
    for k, f in enumerate(frames):
        if labels is not None:
            f = draw_label(f, labels[k], bottom=True)
        r, c = divmod(k, cols)
        y, x = pad + r * (h + pad), pad + c * (w + pad)
        sheet[y : y + h, x : x + w] = f
    return sheet


def write_image(image: np.ndarray, out: str | os.PathLike[str]) -> Path:
    """Write an RGB uint8 image [H, W, 3] atomically (format from the suffix: .png, .jpg, ...)."""
    from PIL import Image

    path = Path(out)
    with atomic_path(path) as tmp:
        try:
            Image.fromarray(np.ascontiguousarray(image)).save(tmp)
        except (KeyError, ValueError) as exc:  # Pillow: unknown extension
            raise ConfigError(f"cannot write image {path}: {exc}") from None
    return path
