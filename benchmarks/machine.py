"""One line naming the machine a benchmark ran on, printed beside its times.

The targets of issue 23 are absolute times, and the project's machines of the same kind differ
three to five times in speed (the same code: CSM at 0.135 m in 41 ms on a 4 Dec machine with
AVX-512, 152 ms on a 5 Dec machine at 2.0 GHz with AVX2 only). This line lets a reader compare
runs from different days; the ratios to peers measured in the same run do not depend on it.
"""
from __future__ import annotations

import platform
from pathlib import Path


def describe() -> str:
    """CPU model, clock [MHz] and the widest vector extension numba can use (Linux; elsewhere
    what :mod:`platform` knows). The cores and the load are printed by each benchmark itself."""
    try:
        info = Path("/proc/cpuinfo").read_text()
    except OSError:
        return f"machine: {platform.processor() or platform.machine()}"
    fields = {}
    for line in info.splitlines():
        key, _, value = line.partition(":")
        fields.setdefault(key.strip(), value.strip())
    flags = set(fields.get("flags", "").split())
    vector = ("AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags
              else "AVX" if "avx" in flags else "SSE")
    mhz = fields.get("cpu MHz", "?")
    try:
        mhz = f"{float(mhz):.0f}"
    except ValueError:
        pass
    return f"machine: {fields.get('model name', platform.machine())}, {mhz} MHz, {vector}"
