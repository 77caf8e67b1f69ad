"""Run a dataset from napari: ``oftimg run`` in a process of its own (the viewer never
freezes, Cancel stops it as SIGTERM stops the command line: workers stopped, nothing
written to the results folder), its progress lines read into a progress bar, and its
one-line error shown as the command line prints it. The panel is part of oftimg's dock
widget (:class:`~oftimg.napari.widget.OftimgWidget`), which opens the results when the
run ends well.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from qtpy.QtCore import QProcess, QProcessEnvironment
from qtpy.QtWidgets import (
    QCheckBox,
    QComboBox,
    QFileDialog,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QProgressBar,
    QPushButton,
    QSpinBox,
    QWidget,
)

from ..progress import EVERY_S_VARIABLE

TRACKING = ("auto", "material", "texture", "none")
PROGRESS_EVERY_S = 0.5  # the command line's progress lines, this often
# "normal: fields, maps: 48/72 frames (67 %), 12 s"
PROGRESS_LINE = re.compile(
    r"^(?P<text>.*?): (?P<done>\d+)/(?P<total>\d+) \w+(?: \(\d+ %\))?, "
    r"\d+ s$"
)


def default_out(dataset) -> Path:
    """Where a run of ``dataset`` writes when the user names no folder: beside it,
    ``<dataset>-oftimg``."""
    dataset = Path(dataset)
    return dataset.with_name(dataset.name + "-oftimg")


def run_arguments(
    dataset,
    out,
    *,
    jobs: int = 0,
    tracking: str = "auto",
    n_u: int = 80,
    n_v: int = 50,
    overwrite: bool = False,
) -> list[str]:
    """The ``oftimg run`` command line (after ``python -m oftimg``) for the panel's
    choices; ``jobs`` 0: the command line's default."""
    if tracking not in TRACKING:
        raise ValueError(f"tracking {tracking!r}: one of {', '.join(TRACKING)}")
    args = [
        "run",
        str(dataset),
        "--out",
        str(out),
        "--tracking",
        tracking,
        "--n-u",
        str(n_u),
        "--n-v",
        str(n_v),
    ]
    if jobs:
        args += ["--jobs", str(jobs)]
    if overwrite:
        args.append("--overwrite")
    return args


def read_progress(line: str) -> tuple[str, int, int] | None:
    """A progress line of the command line's as (what, done, total), else None."""
    match = PROGRESS_LINE.match(line.strip())
    if match is None:
        return None
    return match["text"], int(match["done"]), int(match["total"])


class RunPanel(QGroupBox):
    """Choose a dataset (a folder of meshes or labels, as ``oftimg run`` takes), the
    results folder and the main options; Run starts ``oftimg run`` in its own process
    and Cancel stops it; ``done(results_folder)`` is called when a run ends well."""

    def __init__(self, done=None, parent=None):
        super().__init__("Run a dataset", parent)
        self.done, self.process, self.lines = done, None, []
        form = QFormLayout(self)
        self.dataset, self.out = QLineEdit(), QLineEdit()
        self.dataset.setPlaceholderText("a dataset folder (meshes or labels)")
        self.out.setPlaceholderText("results folder (default: beside the dataset)")
        self.dataset.textChanged.connect(self._suggest_out)
        form.addRow("dataset", self._with_browse(self.dataset, "A dataset folder"))
        form.addRow("results", self._with_browse(self.out, "A folder for the results"))
        self.tracking = QComboBox()
        self.tracking.addItems(TRACKING)
        self.n_u, self.n_v, self.jobs = QSpinBox(), QSpinBox(), QSpinBox()
        for box, low, high, value in (
            (self.n_u, 8, 400, 80),
            (self.n_v, 4, 400, 50),
            (self.jobs, 0, 256, 0),
        ):
            box.setRange(low, high)
            box.setValue(value)
        self.jobs.setSpecialValueText("auto")
        self.overwrite = QCheckBox("replace results oftimg wrote before")
        form.addRow("tracking", self.tracking)
        grid = QWidget()
        row = QHBoxLayout(grid)
        row.setContentsMargins(0, 0, 0, 0)
        for label, box in (("around", self.n_u), ("along", self.n_v)):
            row.addWidget(QLabel(label))
            row.addWidget(box)
        form.addRow("grid nodes", grid)
        form.addRow("workers", self.jobs)
        form.addRow(self.overwrite)
        self.run_button, self.cancel_button = QPushButton("Run"), QPushButton("Cancel")
        self.run_button.clicked.connect(self.start)
        self.cancel_button.clicked.connect(self.cancel)
        self.cancel_button.setEnabled(False)
        buttons = QWidget()
        row = QHBoxLayout(buttons)
        row.setContentsMargins(0, 0, 0, 0)
        row.addWidget(self.run_button)
        row.addWidget(self.cancel_button)
        form.addRow(buttons)
        self.progress = QProgressBar()
        self.progress.setRange(0, 1)
        self.progress.setValue(0)
        self.status = QLabel("")
        self.status.setWordWrap(True)
        form.addRow(self.progress)
        form.addRow(self.status)

    def _with_browse(self, line: QLineEdit, caption: str) -> QWidget:
        box = QWidget()
        row = QHBoxLayout(box)
        row.setContentsMargins(0, 0, 0, 0)
        row.addWidget(line)
        browse = QPushButton("…")
        browse.setMaximumWidth(32)
        browse.clicked.connect(
            lambda: line.setText(QFileDialog.getExistingDirectory(self, caption) or line.text())
        )
        row.addWidget(browse)
        return box

    def _suggest_out(self, text: str) -> None:
        if text and (not self.out.text() or self.out.text() == getattr(self, "_suggested", "")):
            self._suggested = str(default_out(text))
            self.out.setText(self._suggested)

    @property
    def running(self) -> bool:
        return self.process is not None and self.process.state() != QProcess.NotRunning

    def start(self) -> None:
        """Start ``oftimg run`` with the panel's choices."""
        if self.running or not self.dataset.text():
            return
        args = [
            "-m",
            "oftimg",
            *run_arguments(
                self.dataset.text(),
                self.out.text() or default_out(self.dataset.text()),
                jobs=self.jobs.value(),
                tracking=self.tracking.currentText(),
                n_u=self.n_u.value(),
                n_v=self.n_v.value(),
                overwrite=self.overwrite.isChecked(),
            ),
        ]
        self.lines = []
        self.process = QProcess(self)
        env = QProcessEnvironment.systemEnvironment()
        env.insert(EVERY_S_VARIABLE, str(PROGRESS_EVERY_S))
        self.process.setProcessEnvironment(env)
        self.process.readyReadStandardError.connect(self._read)
        self.process.readyReadStandardOutput.connect(self._read)
        self.process.finished.connect(self._finished)
        self.progress.setRange(0, 0)  # busy until the first line
        self._say("starting oftimg run …")
        self.run_button.setEnabled(False)
        self.cancel_button.setEnabled(True)
        self.process.start(sys.executable, args)

    def cancel(self) -> None:
        """Stop the run as SIGTERM stops the command line (nothing written)."""
        if self.running:
            self._say("cancelling …")
            self.process.terminate()

    def _read(self) -> None:
        text = bytes(self.process.readAllStandardError()).decode(errors="replace") + bytes(
            self.process.readAllStandardOutput()
        ).decode(errors="replace")
        for line in text.splitlines():
            if not line.strip():
                continue
            self.lines.append(line)
            progress = read_progress(line)
            if progress is not None:
                what, done, total = progress
                self.progress.setRange(0, max(total, 1))
                self.progress.setValue(done)
                self._say(what)
            elif not line.startswith("report: "):
                self._say(line)

    def _finished(self, exit_code: int, exit_status=None) -> None:
        self._read()
        self.run_button.setEnabled(True)
        self.cancel_button.setEnabled(False)
        self.progress.setRange(0, 1)
        last = self.lines[-1] if self.lines else f"exit code {exit_code}"
        if exit_code != 0:
            self.progress.setValue(0)
            self._say(last, error=True)  # "oftimg: error: ..."
            return
        self.progress.setValue(1)
        out = Path(self.out.text() or default_out(self.dataset.text()))
        self._say(f"done: {out}")
        if self.done is not None:
            self.done(out)

    def _say(self, text: str, error: bool = False) -> None:
        self.status.setText(text)
        self.status.setStyleSheet("color: #ff6b6b;" if error else "")
