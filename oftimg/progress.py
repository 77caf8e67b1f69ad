"""Progress on stderr: frames done, rate, time left (tqdm); silent when not a terminal."""
from __future__ import annotations

import sys

from tqdm import tqdm


class Progress:
    """A progress bar over ``total`` items that stays quiet off a terminal."""

    def __init__(self, total: int, desc: str, *, quiet: bool = False, unit: str = "frame"):
        disable = quiet or not sys.stderr.isatty()
        self._bar = tqdm(total=total, desc=desc, unit=unit, disable=disable,
                         file=sys.stderr, dynamic_ncols=True, leave=False)

    @property
    def shown(self) -> bool:
        """Whether the bar is drawn (not quiet, and stderr is a terminal)."""
        return not self._bar.disable

    @property
    def n(self) -> int:
        """Items done so far."""
        return self._bar.n

    @property
    def total(self) -> int:
        return self._bar.total

    def note(self, text: str) -> None:
        """Show ``text`` after the bar."""
        self._bar.set_postfix_str(text)

    def update(self, done: int) -> None:
        """Set the number of items done."""
        self._bar.update(done - self._bar.n)

    def advance(self, n: int = 1) -> None:
        self._bar.update(n)

    def close(self) -> None:
        self._bar.close()
