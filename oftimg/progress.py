"""Progress on stderr: a bar (tqdm: frames done, rate, time left) on a terminal; off a
terminal (a CI log, a notebook, ``| tee``), a plain line every :data:`LINE_EVERY_S`
seconds, so that a long command is never silent for long."""

from __future__ import annotations

import os
import sys
import threading
import time
import weakref

from tqdm import tqdm

LINE_EVERY_S = 10.0  # off a terminal: a line at least this often while a bar is open
# a program reading the lines (napari's run panel) asks for them more often
EVERY_S_VARIABLE = "OFTIMG_PROGRESS_EVERY_S"
PLURAL = {"mesh": "meshes", "series": "series"}


class Progress:
    """Progress over ``total`` items: a bar on a terminal, a line every
    :data:`LINE_EVERY_S` seconds off one (its ``desc``, the stage :meth:`note` gave,
    items done and their share, seconds so far) and one when it closes; nothing when
    ``quiet``."""

    def __init__(self, total: int, desc: str, *, quiet: bool = False, unit: str = "frame"):
        terminal = sys.stderr.isatty()
        self._bar = tqdm(
            total=total,
            desc=desc,
            unit=unit,
            disable=quiet or not terminal,
            file=sys.stderr,
            dynamic_ncols=True,
            leave=False,
        )
        self._desc, self._unit, self._stage = desc, unit, ""
        self._count, self._total, self._started = 0, total, time.monotonic()
        self._stop = threading.Event()
        self._lines = None
        if not quiet and not terminal:
            self._lines = threading.Thread(
                target=_every_interval, args=(weakref.ref(self), self._stop), daemon=True
            )
            self._lines.start()

    @property
    def shown(self) -> bool:
        """Whether the bar is drawn (not quiet, and stderr is a terminal)."""
        return not self._bar.disable

    @property
    def reporting(self) -> bool:
        """Whether progress is reported at all (a bar, or lines off a terminal): whether
        counting it is worth the cost."""
        return self.shown or self._lines is not None

    @property
    def n(self) -> int:
        """Items done so far."""
        return self._count

    @property
    def total(self) -> int:
        return self._total

    def note(self, text: str) -> None:
        """Show ``text`` (the stage now under way) after the bar, or in the lines."""
        self._stage = text
        self._bar.set_postfix_str(text)

    def update(self, done: int) -> None:
        """Set the number of items done."""
        self.advance(done - self._count)

    def advance(self, n: int = 1) -> None:
        self._count += n
        self._bar.update(n)

    def restart(self, stage: str) -> None:
        """Count the same total again from 0, for the stage ``stage`` (:meth:`note`)."""
        self._count = 0
        self._bar.reset(total=self._total)
        self.note(stage)

    def close(self) -> None:
        """End the bar (off a terminal: a last line, "done", unless an error is on its
        way up: its one line is then the last)."""
        if self._stop.is_set():
            return
        self._stop.set()
        if self._lines is not None:
            if self._lines is not threading.current_thread():
                self._lines.join()
            if sys.exc_info()[0] is None:  # closed in a finally an error passes
                self._stage = "done"
                self._line()
        self._bar.close()

    def line_text(self) -> str:
        """The line written off a terminal: ``"normal_0: fields, maps: 48/48 frames
        (100 %), 12 s"``."""
        share = f" ({100 * self._count / self._total:.0f} %)" if self._total else ""
        stage = f": {self._stage}" if self._stage else ""
        units = PLURAL.get(self._unit, self._unit + "s")
        return (
            f"{self._desc}{stage}: {self._count}/{self._total} {units}{share}, "
            f"{time.monotonic() - self._started:.0f} s"
        )

    def _line(self) -> None:
        print(self.line_text(), file=sys.stderr, flush=True)

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class FramePasses:
    """The progress callback of passes over the same frames: ``bar`` (a
    :class:`Progress` over the frames) counts each pass's frames from 0, its stage
    naming the pass ("seams (pass 1 of 2)"), so that a 48-frame dataset counts 48
    frames, not 96."""

    def __init__(self, bar: Progress, stages: tuple[str, ...]):
        self.bar, self.stages, self.k = bar, stages, 0
        bar.note(self._stage())

    def _stage(self) -> str:
        return f"{self.stages[self.k]} (pass {self.k + 1} of {len(self.stages)})"

    def __call__(self) -> None:
        if self.bar.n >= self.bar.total and self.k + 1 < len(self.stages):
            self.k += 1
            self.bar.restart(self._stage())
        self.bar.advance()


def _every_interval(progress: weakref.ref, stop: threading.Event) -> None:
    """A line every :data:`LINE_EVERY_S` seconds (or as the environment variable
    :data:`EVERY_S_VARIABLE` says) until the bar is closed or gone (a bar left open by
    an error does not write on for ever)."""
    every_s = float(os.environ.get(EVERY_S_VARIABLE) or LINE_EVERY_S)
    while not stop.wait(every_s):
        bar = progress()
        if bar is None:
            return
        bar._line()
        del bar
