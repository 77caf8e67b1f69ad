"""Freed memory given back between a run's stages (oftimg.memory): on glibc the heap's
free pages return to the system; elsewhere a no-op that says so."""

import os
import subprocess
import sys
import textwrap

import pytest

from oftimg.memory import release_freed

# Run in a fresh interpreter: in the suite's process the heap already holds other tests'
# holes, which decide where the blocks land and whether freeing them alone shrinks the
# heap (it did in CI: 300 MB back without a trim). glibc's own trim-on-free is switched
# off by its threshold so that only release_freed can give the pages back.
_HEAP_WITH_HOLES = textwrap.dedent("""
    import numpy as np
    from oftimg.memory import release_freed

    def rss_mb():
        with open("/proc/self/status") as status:
            return int(status.read().split("VmRSS:")[1].split()[0]) / 1024

    blocks, pins = [], []
    for _ in range(6400):
        blocks.append(np.ones(8192))     # 64 kB, written: resident
        pins.append(np.ones(256))        # 2 kB from malloc too: the heap cannot shrink past it
    held = rss_mb()
    del blocks
    before = rss_mb()
    release_freed()
    after = rss_mb()
    print(held, before, after)
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc_trim")
def test_freed_heap_pages_go_back_to_the_system():
    """400 MB in 64 kB arrays (the heap, under the mmap threshold), each beside a small
    object that stays: freeing the arrays leaves the heap full of holes, which only a
    trim returns."""
    if not release_freed():
        pytest.skip("no malloc_trim in this C library (not glibc)")
    env = dict(
        os.environ,
        MALLOC_TRIM_THRESHOLD_=str(2**40),
        MALLOC_MMAP_THRESHOLD_=str(2**20),
        MALLOC_ARENA_MAX="1",
    )
    out = subprocess.run(
        [sys.executable, "-c", _HEAP_WITH_HOLES],
        env=env,
        check=True,
        capture_output=True,
        text=True,
        timeout=300,
    ).stdout
    held, before, after = map(float, out.split())
    assert held > 400  # the blocks were resident
    assert before > held - 100  # freeing alone gave little back
    assert before - after > 300, (held, before, after)  # the trim gave it back
