"""How fast a result opens and scrubs in napari (issue 63: open under 5 s, a slider
step under 50 ms a frame), headless (napari's ViewerModel: no drawing, which a Qt
window adds).

    python scripts/bench_napari.py RESULTS/<name>

Prints the seconds to open the folder both ways (the reader's layers with every frame
in them; WallsOverTime's one frame a layer) and the median and worst milliseconds of a
time-slider step for each.
"""
from __future__ import annotations

import argparse
import time

import numpy as np


def steps_ms(viewer, n_t: int) -> list[float]:
    times = []
    for t in list(range(0, n_t, max(1, n_t // 30))):
        tick = time.perf_counter()
        viewer.dims.set_current_step(0, t)
        times.append(1000 * (time.perf_counter() - tick))
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("results", help="one dataset's results folder")
    folder = parser.parse_args().results
    from napari.components import ViewerModel

    from oftimg.napari.reader import results_layers
    from oftimg.napari.walls import WallsOverTime

    viewer = ViewerModel(ndisplay=3)
    tick = time.perf_counter()
    for data, kwargs, _ in results_layers(folder):
        viewer.add_surface(data, **kwargs)
    opened = time.perf_counter() - tick
    n_t = viewer.dims.nsteps[0]
    ms = steps_ms(viewer, n_t)
    print(f"reader (every frame in each layer): open {opened:.2f} s, {n_t} frames; "
          f"a step {np.median(ms):.1f} ms median, {max(ms):.1f} ms worst")
    viewer = ViewerModel(ndisplay=3)
    tick = time.perf_counter()
    WallsOverTime(viewer, folder)
    opened = time.perf_counter() - tick
    ms = steps_ms(viewer, n_t)
    print(f"WallsOverTime (one frame a layer): open {opened:.2f} s; "
          f"a step {np.median(ms):.1f} ms median, {max(ms):.1f} ms worst")


if __name__ == "__main__":
    main()
