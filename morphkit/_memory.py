"""Memory this process may still allocate: the one answer every up-front memory check compares its estimate with."""

from __future__ import annotations

import os
import re
from pathlib import Path

__all__ = ["available_memory"]


def available_memory() -> int | None:
    """Bytes this process may still allocate: the system's available memory, less under a cgroup limit
    (a container); ``None`` where neither can be read."""
    found: list[int] = []
    try:
        meminfo = Path("/proc/meminfo").read_text()
        m = re.search(r"^MemAvailable:\s*(\d+) kB", meminfo, flags=re.M)
        if m is not None:
            found.append(int(m.group(1)) * 1024)
    except OSError:
        pass
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        used = Path("/sys/fs/cgroup/memory.current").read_text().strip()
        if limit.isdigit() and used.isdigit():
            found.append(max(int(limit) - int(used), 0))
    except OSError:
        pass
    if not found and hasattr(os, "sysconf"):
        try:
            found.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError):
            pass
    return min(found) if found else None
