"""Progress off a terminal (issue 62): a CI log, a notebook or `| tee` gets a plain line
at least every LINE_EVERY_S seconds, with the stage and the share done; nothing when
quiet; no line after the bar is closed, or once it is gone."""

import gc
import time

from oftimg import progress
from oftimg.progress import Progress


def test_off_a_terminal_a_line_comes_every_interval_with_the_stage_and_share(monkeypatch, capsys):
    monkeypatch.setattr(progress, "LINE_EVERY_S", 0.05)
    with Progress(40, "normal_0") as bar:
        assert not bar.shown  # pytest's stderr is no terminal
        bar.advance(10)
        bar.note("fields, maps")
        time.sleep(0.3)
    lines = capsys.readouterr().err.splitlines()
    assert "normal_0: fields, maps: 10/40 frames (25 %)" in lines[-2]
    assert lines[-1].startswith("normal_0: done: 10/40 frames (25 %)")  # and when it ends
    assert len(lines) >= 4
    time.sleep(0.2)
    assert capsys.readouterr().err == ""  # closed: silent


def test_a_unit_has_its_plural():
    bar = Progress(72, "normal_0: checking meshes", unit="mesh", quiet=True)
    bar.advance(9)
    assert bar.line_text().startswith("normal_0: checking meshes: 9/72 meshes (12 %)")
    bar.close()


def test_quiet_writes_nothing(monkeypatch, capsys):
    monkeypatch.setattr(progress, "LINE_EVERY_S", 0.05)
    bar = Progress(10, "x", quiet=True)
    bar.advance(3)
    time.sleep(0.2)
    bar.close()
    assert capsys.readouterr().err == ""
    assert bar.n == 3 and bar.total == 10


def test_a_bar_left_open_by_an_error_stops_writing_once_it_is_gone(monkeypatch, capsys):
    monkeypatch.setattr(progress, "LINE_EVERY_S", 0.05)
    bar = Progress(10, "left open")
    thread = bar._lines
    del bar
    gc.collect()
    thread.join(timeout=2)
    assert not thread.is_alive()
    capsys.readouterr()


def test_a_bar_closed_by_an_error_leaves_the_error_the_last_line(capsys):
    try:
        with Progress(5, "emb: checking meshes", unit="mesh") as bar:
            bar.advance(5)
            raise ValueError("f2.ply: is a folder, not a file")
    except ValueError:
        pass
    assert capsys.readouterr().err == ""


def test_passes_over_the_frames_count_the_frames_once_each_pass():
    """A 48-frame label run counted "49/96 frames" and "done: 96/96"."""
    from oftimg.progress import FramePasses

    bar = Progress(48, "emb", quiet=True)
    step = FramePasses(bar, ("seams", "grids and sections"))
    assert bar.line_text().startswith("emb: seams (pass 1 of 2): 0/48 frames (0 %)")
    for _ in range(48):
        step()
    assert bar.line_text().startswith("emb: seams (pass 1 of 2): 48/48 frames (100 %)")
    step()
    assert bar.line_text().startswith("emb: grids and sections (pass 2 of 2): 1/48 frames (2 %)")
    for _ in range(47):
        step()
    assert bar.n == bar.total == 48
    bar.close()


def test_by_embryo_the_bar_says_what_each_worker_is_doing(tmp_path):
    """A whole embryo in a worker reports its frames, then each stage by name (the bar
    stood at 25 % for 40 s while two embryos made their files, saying nothing), and a
    third of its tail as the files begin; the bar shows the stages of those under way."""
    from oftimg import api
    from oftimg.analysis.pipeline import PipelineOptions
    from oftimg.io.dataset import load_dataset
    from oftimg.synthetic.phantom import sample_params, write_phantom

    ds = load_dataset(
        write_phantom(
            tmp_path / "e0",
            sample_params("normal", 0, n_frames=6, vertices_min=800, vertices_max=900),
            name="e0",
        )
    )
    reports = []
    queue = type("Queue", (), {"put": lambda self, report: reports.append(report)})()
    api.embryo_task(
        ds, api._validated(ds, None, True), PipelineOptions(), 30.0, queue, figures=False
    )
    stages = [r for r in reports if isinstance(r, tuple)]
    assert stages == [("e0", "fields, maps, shape modes"), ("e0", "files"), ("e0", None)]
    steps = [r for r in reports if not isinstance(r, tuple)]
    tail = api._tail_frames(6)
    assert sum(steps) == 2 * 6 + tail  # every frame of both passes, the tail
    assert steps[reports.index(("e0", "files")) - 2] == tail // 3  # as the files begin

    bar, running = Progress(100, "2 datasets", quiet=True), {}
    for report in (5, ("e0", "figures, videos"), ("e1", "fields, maps, shape modes"), ("e0", None)):
        api._show_report(report, bar, running)
    assert bar.n == 5 and bar._stage == "e1: fields, maps, shape modes"
    api._show_report(("e1", "figures, videos"), bar, running)
    api._show_report(("e2", "fields, maps, shape modes"), bar, running)
    assert bar._stage == "e1: figures, videos; e2: fields, maps, shape modes"
