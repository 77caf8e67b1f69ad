"""Running a dataset from napari's dock widget (issue 63, point 4): ``oftimg run`` in a
process of its own, its progress in a bar, Cancel as SIGTERM (nothing written), the
command line's one-line error shown, the results opened when the run ends well."""

import numpy as np
import pytest

pytest.importorskip("napari")
pytest.importorskip("qtpy.QtWidgets")
pytest.importorskip("pytestqt")

from oftimg.napari.run import default_out, read_progress, run_arguments  # noqa: E402

pytestmark = pytest.mark.long  # make test-long (accuracy, rendering, whole runs)

RUN_S = 240_000  # ms: a small phantom's run, on a busy machine


def test_the_panel_s_choices_are_the_command_line_s():
    assert run_arguments(
        "/d/heart", "/r", jobs=2, tracking="material", n_u=40, n_v=20, overwrite=True
    ) == [
        "run",
        "/d/heart",
        "--out",
        "/r",
        "--tracking",
        "material",
        "--n-u",
        "40",
        "--n-v",
        "20",
        "--jobs",
        "2",
        "--overwrite",
    ]
    assert "--jobs" not in run_arguments("/d/heart", "/r")  # 0: the default
    assert str(default_out("/d/heart")) == "/d/heart-oftimg"
    with pytest.raises(ValueError, match="tracking 'fast'"):
        run_arguments("/d/heart", "/r", tracking="fast")


def test_a_progress_line_of_the_command_line_is_read_back():
    from oftimg.progress import Progress

    bar = Progress(72, "normal", quiet=True)
    bar.note("fields, maps")
    bar.update(48)
    assert read_progress(bar.line_text()) == ("normal: fields, maps", 48, 72)
    assert read_progress("error: /d: no dataset") is None


@pytest.fixture
def panel_widget(qtbot):
    from napari.components import ViewerModel

    from oftimg.napari.widget import OftimgWidget

    widget = OftimgWidget(ViewerModel(ndisplay=3))
    qtbot.addWidget(widget)
    widget.run_panel.jobs.setValue(1)
    return widget


def test_a_run_from_the_panel_shows_progress_and_opens_its_results(
    panel_widget, qtbot, phantom_normal, tmp_path
):
    panel = panel_widget.run_panel
    panel.dataset.setText(str(phantom_normal))
    assert panel.out.text() == str(default_out(phantom_normal))  # suggested
    panel.out.setText(str(tmp_path / "results"))
    seen = []
    panel.progress.valueChanged.connect(lambda v: seen.append((v, panel.progress.maximum())))
    panel.start()
    assert panel.running and not panel.run_button.isEnabled()
    qtbot.waitUntil(lambda: not panel.running, timeout=RUN_S)
    assert panel.status.text() == f"done: {tmp_path / 'results'}", panel.lines[-3:]
    assert any(0 < v < m for v, m in seen)  # the bar moved between ends
    assert panel_widget.walls is not None  # the results opened
    assert "normal" in panel_widget.status.text()
    assert np.isfinite(panel_widget.views.field).any()


def test_cancel_stops_the_run_and_nothing_is_written(panel_widget, qtbot, phantom_normal, tmp_path):
    panel = panel_widget.run_panel
    panel.dataset.setText(str(phantom_normal))
    panel.out.setText(str(tmp_path / "results"))
    panel.start()
    qtbot.waitUntil(
        lambda: panel.progress.maximum() > 1 or not panel.running, timeout=RUN_S
    )  # under way: a progress line came
    assert panel.running
    panel.cancel()
    qtbot.waitUntil(lambda: not panel.running, timeout=60_000)
    assert panel.status.text().startswith("oftimg: terminated (SIGTERM)"), panel.lines
    assert "no results were written" in panel.status.text()
    assert not (tmp_path / "results").exists()
    assert panel.run_button.isEnabled() and panel_widget.walls is None


def test_bad_input_shows_the_command_line_s_one_line(panel_widget, qtbot, tmp_path):
    panel = panel_widget.run_panel
    (tmp_path / "empty").mkdir()
    panel.dataset.setText(str(tmp_path / "empty"))
    panel.start()
    qtbot.waitUntil(lambda: not panel.running, timeout=60_000)
    status = panel.status.text()
    assert status.startswith(f"oftimg: error: {tmp_path / 'empty'}: "), status
    assert "\n" not in status
    assert not default_out(tmp_path / "empty").exists()
