"""The one error hierarchy of morphkit.

Every error a user can cause derives from :class:`MorphkitError` and carries a
:class:`SourceLocation` (file and line) when one is known. Only ``morphkit.cli`` turns an
error into ``error: <file>:<line>: <message>`` and exit code 2.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "ConfigError",
    "DescriptionError",
    "GraphError",
    "MorphkitError",
    "MotionFormatError",
    "RunError",
    "SourceLocation",
]


@dataclass(frozen=True)
class SourceLocation:
    """Where in a user's file something was written."""

    path: str | None = None
    """File path as the user gave it, or ``None`` for objects built in code."""
    line: int | None = None
    """1-based line number, or ``None`` where the format cannot tell."""

    def __str__(self) -> str:
        path = self.path if self.path is not None else "<input>"
        return f"{path}:{self.line}" if self.line is not None else path

    def at_line(self, line: int | None) -> SourceLocation:
        """The same file at another line."""
        return SourceLocation(self.path, line)


class MorphkitError(Exception):
    """Root of every error morphkit raises for bad input.

    Args:
        message: What is wrong, naming the offending value and the valid choices.
        location: Where it was written, when known.
    """

    def __init__(self, message: str, *, location: SourceLocation | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.location = location

    def __str__(self) -> str:
        return f"{self.location}: {self.message}" if self.location is not None else self.message


class DescriptionError(MorphkitError):
    """A morphology description (YAML, URDF, USD, BVH hierarchy) cannot be parsed or has a bad value."""


class GraphError(MorphkitError):
    """The skeleton graph is structurally invalid (cycle, missing link, duplicate name, ...)."""


class MotionFormatError(MorphkitError):
    """A motion file (BVH MOTION section, NPZ, USD time samples) is malformed or inconsistent."""


class ConfigError(MorphkitError):
    """A configuration value or command-line argument is invalid."""


class RunError(MorphkitError):
    """A training run folder or checkpoint cannot be used (another trainer's or creature's, truncated, foreign)."""
