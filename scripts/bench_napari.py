"""How fast a result opens and scrubs in napari (issue 63: open under 5 s, a slider
step redrawn under 50 ms a frame).

    python scripts/bench_napari.py RESULTS/<name>               # headless, no drawing
    xvfb-run -a python scripts/bench_napari.py RESULTS/<name> --window

Headless (napari's ViewerModel): the seconds to open the folder both ways (the
reader's layers with every frame in them; WallsOverTime's one frame a layer) and the
milliseconds of a time-slider step, nothing drawn. ``--window``: napari's window with
oftimg's dock widget, as a user has it: the seconds from ``open`` to the first frame
drawn, and the milliseconds from a slider step to the 3-D canvas and the linked views
redrawn, with all three walls shown and with the outer wall alone. Under Xvfb the 3-D
canvas is drawn by Mesa's software OpenGL, on the CPU.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def steps_ms(viewer, n_t: int, after=lambda: None) -> list[float]:
    """Milliseconds of each of ~30 slider steps spread over the cycle, ``after()``
    (the drawing) included."""
    times = []
    for t in list(range(0, n_t, max(1, n_t // 30))):
        tick = time.perf_counter()
        viewer.dims.set_current_step(0, t)
        after()
        times.append(1000 * (time.perf_counter() - tick))
    return times


def summary(ms: list[float]) -> str:
    return f"{np.median(ms):.1f} ms median, {max(ms):.1f} ms worst"


def headless(folder) -> None:
    from napari.components import ViewerModel

    from oftimg.napari.reader import results_layers
    from oftimg.napari.walls import WallsOverTime

    viewer = ViewerModel(ndisplay=3)
    tick = time.perf_counter()
    for data, kwargs, kind in results_layers(folder):
        getattr(viewer, f"add_{kind}")(data, **kwargs)
    opened = time.perf_counter() - tick
    n_t = viewer.dims.nsteps[0]
    print(
        f"reader (every frame in each layer): open {opened:.2f} s, {n_t} frames; "
        f"a step {summary(steps_ms(viewer, n_t))}"
    )
    viewer = ViewerModel(ndisplay=3)
    tick = time.perf_counter()
    WallsOverTime(viewer, folder)
    opened = time.perf_counter() - tick
    print(
        f"WallsOverTime (one frame a layer): open {opened:.2f} s; "
        f"a step {summary(steps_ms(viewer, n_t))}"
    )


def window(folder) -> None:
    import napari
    from qtpy.QtWidgets import QApplication

    from oftimg.napari.widget import OftimgWidget

    viewer = napari.Viewer(ndisplay=3)
    widget = OftimgWidget(viewer)
    viewer.window.add_dock_widget(widget, area="right")
    QApplication.processEvents()
    scene = viewer.window._qt_viewer.canvas._scene_canvas  # the 3-D canvas (vispy)

    draws = []
    scene.events.draw.connect(lambda event: draws.append(1))

    def drawn():
        """Qt's events until the 3-D canvas has painted (the views' blit with it)."""
        before = len(draws)
        for _ in range(50):
            QApplication.processEvents()
            if len(draws) > before:
                return
        raise RuntimeError("the 3-D canvas did not paint")

    tick = time.perf_counter()
    widget.open(folder)
    widget.canvas.draw()
    drawn()
    opened = time.perf_counter() - tick
    n_t = viewer.dims.nsteps[0]
    print(f"window: open {opened:.2f} s to the first frame drawn, {n_t} frames")
    volumes = widget.walls.volumes
    shown = {layer.name: layer.visible for layer in volumes}
    for layer in volumes:
        layer.visible = False
    print(f"window, three walls shown: a step redrawn in {summary(steps_ms(viewer, n_t, drawn))}")
    if volumes:
        for layer in volumes:
            layer.visible = shown[layer.name]
        print(
            f"window, as opened (three walls, "
            f"{', '.join(n for n, v in shown.items() if v) or 'no volume'}): a step redrawn "
            f"in {summary(steps_ms(viewer, n_t, drawn))}"
        )
        for layer in volumes:
            layer.visible = True
        print(
            f"window, three walls and the volumes ({', '.join(shown)}) shown: a step "
            f"redrawn in {summary(steps_ms(viewer, n_t, drawn))}"
        )
        viewer.dims.ndisplay = 2
        print(
            f"window, the same in napari's 2-D view (a slice): a step redrawn in "
            f"{summary(steps_ms(viewer, n_t, drawn))}"
        )
        viewer.dims.ndisplay = 3
        for layer in volumes:
            layer.visible = False
    for wall in ("inner", "lumen"):
        widget.walls.layers[wall].visible = False
    print(
        f"window, the outer wall alone: a step redrawn in {summary(steps_ms(viewer, n_t, drawn))}"
    )
    viewer.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("results", help="one dataset's results folder")
    parser.add_argument(
        "--window",
        action="store_true",
        help="napari's window with the dock widget (needs a screen or Xvfb)",
    )
    args = parser.parse_args()
    (window if args.window else headless)(args.results)


if __name__ == "__main__":
    main()
