"""Freed memory given back between a run's stages (oftimg.memory): on glibc the heap's
free pages return to the system; elsewhere a no-op that says so."""
import sys

import numpy as np
import pytest

from oftimg.memory import release_freed


def rss_mb() -> float:
    with open("/proc/self/status") as status:
        return int(status.read().split("VmRSS:")[1].split()[0]) / 1024


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc_trim")
def test_freed_heap_pages_go_back_to_the_system():
    """400 MB in 64 kB arrays (the heap, under the mmap threshold), each beside a small
    object that stays: freeing the arrays leaves the heap full of holes, which only a
    trim returns."""
    if not release_freed():
        pytest.skip("no malloc_trim in this C library (not glibc)")
    blocks, pins = [], []
    for _ in range(6400):
        blocks.append(np.ones(8192))               # 64 kB, written: resident
        pins.append(np.ones(256))                   # 2 kB from malloc too (not Python's
                                                    # small-object arenas): the heap cannot
                                                    # shrink from its top past it
    held = rss_mb()
    del blocks
    before = rss_mb()
    assert release_freed()
    after = rss_mb()
    assert held > 400                               # the blocks were resident
    assert before > held - 100                      # freeing alone gave little back
    assert before - after > 300, (held, before, after)   # the trim gave it back
    del pins
