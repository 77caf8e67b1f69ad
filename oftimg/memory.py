"""Giving freed memory back to the system between the stages of a run.

glibc's allocator keeps what numpy frees in the process's heap for reuse when the
blocks are below its (self-raising) mmap threshold: after the per-frame results are
stacked and dropped, the main process of a 195-frame embryo held 120 MB it no longer
used, and 0.78 GB at its peak instead of 0.64 (docs/performance.md). ``malloc_trim``
returns those pages; elsewhere (macOS, Windows, musl) this is a no-op.
"""

from __future__ import annotations

import ctypes
import ctypes.util
from functools import lru_cache


@lru_cache(maxsize=1)
def _malloc_trim():
    """glibc's ``malloc_trim``, or None where the C library has none."""
    name = ctypes.util.find_library("c")
    try:
        return ctypes.CDLL(name).malloc_trim if name else None
    except (OSError, AttributeError):
        return None


def release_freed() -> bool:
    """Return the heap's free pages to the system (glibc ``malloc_trim(0)``); whether
    it could be asked."""
    trim = _malloc_trim()
    if trim is None:
        return False
    trim(0)
    return True
