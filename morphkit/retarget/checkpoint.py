"""Checkpoint files: one dict that is the whole training state, written atomically, read safely.

A checkpoint holds only tensors and builtins (dicts, lists, tuples, ints, floats, strings,
``None``), so ``torch.load(path, weights_only=True)`` reads it without unpickling code.
:func:`rng_state` captures every random number generator a run draws from — torch CPU, CUDA
when present, NumPy's global state and a run-owned ``numpy.random.Generator``, Python's
``random`` and an optional run-owned ``torch.Generator`` — in that form; :func:`set_rng_state`
puts them back.
"""

from __future__ import annotations

import errno
import os
import random
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import torch

from morphkit._atomic import atomic_path
from morphkit.errors import RunError, SourceLocation

__all__ = [
    "CHECKPOINT_FORMAT",
    "CHECKPOINT_VERSION",
    "load_checkpoint",
    "load_module_state",
    "rng_state",
    "save_checkpoint",
    "set_rng_state",
]

CHECKPOINT_FORMAT = "morphkit-checkpoint"
"""Value of the ``format`` key that marks a morphkit checkpoint."""
CHECKPOINT_VERSION = 1
"""Layout version; a newer one than this code knows is refused."""


def save_checkpoint(path: str | os.PathLike[str], payload: dict[str, Any]) -> Path:
    """Write ``payload`` (tensors and builtins only) to ``path`` atomically, marked as a morphkit checkpoint.

    A crash while writing leaves the previous checkpoint in place.
    """
    with atomic_path(path) as tmp:
        try:
            torch.save({"format": CHECKPOINT_FORMAT, "version": CHECKPOINT_VERSION, **payload}, tmp)
        except RuntimeError as exc:
            # torch's zip writer reports a full disk as a RuntimeError ("file write failed"): an OSError naming
            # the checkpoint instead, which the CLI prints as one line.
            raise OSError(errno.EIO, f"cannot write checkpoint ({_reason(exc)})", os.fspath(path)) from exc
    return Path(path)


def load_module_state(module: Any, state: dict[str, Any], *, path: str | os.PathLike[str], what: str) -> None:
    """``module.load_state_dict(state)``, a state that does not fit (sizes, names) a :class:`RunError` naming ``path``.

    Args:
        module: The module (or optimiser) built from the run's config.
        state: Its state from the checkpoint at ``path``.
        path: The checkpoint file.
        what: What the state is, for the message (``"the generator"``).
    """
    try:
        module.load_state_dict(state)
    except (RuntimeError, ValueError, KeyError) as exc:
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        detail = next((line for line in lines if line.startswith(("size mismatch", "Missing", "Unexpected"))), "")
        raise RunError(
            f"checkpoint state of {what} does not fit the network its config.yaml builds"
            + (f" ({detail.rstrip('.')})" if detail else "")
            + ": the config was edited after training, or belongs to another run",
            location=SourceLocation(os.fspath(path)),
        ) from None


def load_checkpoint(path: str | os.PathLike[str], *, map_location: str | torch.device = "cpu") -> dict[str, Any]:
    """Read a checkpoint written by :func:`save_checkpoint` with ``weights_only=True``.

    Raises:
        RunError: The file is missing, truncated, not a torch file, holds pickled objects, or is
            not a morphkit checkpoint (or one of a newer layout); the message names the file.
    """
    where = SourceLocation(os.fspath(path))
    try:
        with open(path, "rb") as f:
            magic = f.read(4)
    except FileNotFoundError as exc:
        raise RunError("checkpoint not found", location=where) from exc
    except OSError as exc:
        raise RunError(f"cannot read checkpoint: {exc.strerror}", location=where) from exc
    if magic != b"PK\x03\x04":
        raise RunError("not a torch checkpoint (torch.save writes a zip archive; this is not one)", location=where)
    try:
        data = torch.load(path, map_location=map_location, weights_only=True)
    except (RuntimeError, EOFError, zipfile.BadZipFile, ValueError, OSError) as exc:
        raise RunError(f"checkpoint is truncated or damaged ({_reason(exc)})", location=where) from exc
    except Exception as exc:  # pickle.UnpicklingError: objects weights_only refuses
        raise RunError(f"checkpoint holds objects a safe load refuses ({_reason(exc)})", location=where) from exc
    if not isinstance(data, dict) or data.get("format") != CHECKPOINT_FORMAT:
        raise RunError("not a morphkit checkpoint (no 'format: morphkit-checkpoint' entry)", location=where)
    if not isinstance(data.get("version"), int) or data["version"] > CHECKPOINT_VERSION:
        raise RunError(
            f"checkpoint layout version {data.get('version')!r} is newer than this morphkit reads "
            f"({CHECKPOINT_VERSION})",
            location=where,
        )
    return data


def _reason(exc: BaseException) -> str:
    """The informative line of a torch.load error (its 'Unsupported global' line when there is one)."""
    lines = [line.strip() for line in str(exc).strip().splitlines() if line.strip()]
    pick = next((line for line in lines if "Unsupported global" in line), lines[0] if lines else "")
    return f"{type(exc).__name__}: {pick}" if pick else type(exc).__name__


def rng_state(
    *, numpy_generator: np.random.Generator | None = None, torch_generator: torch.Generator | None = None
) -> dict[str, Any]:
    """Every RNG state as tensors and builtins (``weights_only``-loadable)."""
    state: dict[str, Any] = {
        "torch": torch.get_rng_state(),
        "python": _python_to_plain(random.getstate()),
        "numpy_global": _numpy_to_plain(np.random.get_state(legacy=False)),  # noqa: NPY002 - libraries still draw from it
    }
    if torch.cuda.is_available() and torch.cuda.is_initialized():
        state["cuda"] = torch.cuda.get_rng_state_all()
    if numpy_generator is not None:
        state["numpy"] = _numpy_to_plain(numpy_generator.bit_generator.state)
    if torch_generator is not None:
        state["torch_generator"] = torch_generator.get_state()
    return state


def set_rng_state(
    state: dict[str, Any],
    *,
    numpy_generator: np.random.Generator | None = None,
    torch_generator: torch.Generator | None = None,
) -> None:
    """Restore the states captured by :func:`rng_state` (entries absent from ``state`` are left alone)."""
    torch.set_rng_state(state["torch"].cpu())
    version, internal, gauss = state["python"]
    random.setstate((version, tuple(internal), gauss))
    np.random.set_state(_plain_to_numpy(state["numpy_global"]))  # noqa: NPY002 - see rng_state
    if "cuda" in state and torch.cuda.is_available():
        cuda_states = state["cuda"][: torch.cuda.device_count()]
        torch.cuda.set_rng_state_all([s.cpu() for s in cuda_states])
    if numpy_generator is not None and "numpy" in state:
        numpy_generator.bit_generator.state = _plain_to_numpy(state["numpy"])
    if torch_generator is not None and "torch_generator" in state:
        torch_generator.set_state(state["torch_generator"].cpu())


def _python_to_plain(state: tuple[Any, ...]) -> list[Any]:
    version, internal, gauss = state
    return [version, list(internal), gauss]


def _numpy_to_plain(value: Any) -> Any:
    """NumPy arrays → tensors (tagged), NumPy scalars → ints/floats, containers recursively."""
    if isinstance(value, np.ndarray):
        # torch has few unsigned dtypes: MT19937's uint32 key travels as int64
        data = value.astype(np.int64) if value.dtype == np.uint32 else value.copy()
        return {"__ndarray__": torch.from_numpy(data), "dtype": str(value.dtype)}
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {k: _numpy_to_plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_numpy_to_plain(v) for v in value]
    return value


def _plain_to_numpy(value: Any) -> Any:
    if isinstance(value, dict):
        if "__ndarray__" in value:
            return value["__ndarray__"].numpy().astype(value["dtype"])
        return {k: _plain_to_numpy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain_to_numpy(v) for v in value]
    return value
