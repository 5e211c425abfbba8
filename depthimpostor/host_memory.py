"""The machine's memory, as the checks that must run before any GL context exists read it."""

from __future__ import annotations

import os


def available_memory() -> int | None:
    """The machine's available memory in bytes (Linux's MemAvailable), or its physical memory;
    None where neither can be read."""
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError):
        return None
