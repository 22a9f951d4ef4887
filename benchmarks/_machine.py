"""The machine line every benchmark prints."""

from __future__ import annotations

import os
import platform


def machine() -> str:
    """CPU model, core count and OS, as a benchmark header states them."""
    cpu = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}"
