"""What the docs promise: every file a run writes is in docs/guide.md's list, and every
file listed is written (issue 54; the list read from its "Every file a run writes"
block); each gallery example runs when its code is copied into a file in an empty
folder (issue 75), and a script that calls oftimg at its top level (no ``if __name__ ==
"__main__":``) gets told so and runs."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import oftimg

pytestmark = pytest.mark.long  # make test-long (accuracy, rendering, whole runs)

GUIDE = Path(__file__).resolve().parent.parent / "docs" / "guide.md"


def documented() -> set[str]:
    text = GUIDE.read_text()
    block = text.split("### Every file a run writes", 1)[1].split("```text", 1)[1]
    block = block.split("```", 1)[0]
    return {line.split()[0] for line in block.strip().splitlines()}


def _pattern(path: str, names: set[str]) -> str:
    """A written file's path as the list writes it."""
    parts = path.split("/")
    parts = ["<name>" if p in names else p for p in parts]
    parts[-1] = re.sub(r"^f\d+\.ply$", "f<frame>.ply", parts[-1])
    if "figures" in parts[:-1]:  # each figure's PDF and SVG, documented with its PNG
        parts[-1] = re.sub(r"\.(pdf|svg)$", ".png", parts[-1])
    return "/".join(parts)


EXAMPLES = sorted((GUIDE.parent / "examples").glob("plot_*.py"))


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """A cache folder holding the examples' cohort (2 embryos per group of 12 frames,
    enough for the group comparison's tests and figures), made once here; ``make
    test-long`` names one in $OFTIMG_CACHE that the docs' build then reuses (2 min)."""
    given = os.environ.get("OFTIMG_CACHE")
    folder = Path(given) if given else tmp_path_factory.mktemp("cache")
    folder.mkdir(parents=True, exist_ok=True)
    results = oftimg.example_results(folder)
    assert sorted(p.name for p in results.iterdir() if (p / "summary.json").is_file()) == [
        "banded_0",
        "banded_1",
        "normal_0",
        "normal_1",
    ]
    return folder


def test_the_demo_writes_the_documented_files(cache):
    """The demo's every file (its figures as PNG and PDF), on the examples' cohort
    (``oftimg.demo``'s own, smaller)."""
    out = oftimg.example_results(cache).parent
    names = {p.name for p in (out / "data").iterdir()}
    written = set()
    for f in out.rglob("*"):
        if f.is_file() and not any(part.startswith(".") for part in f.relative_to(out).parts):
            rel = f.relative_to(out).as_posix()
            rel = "OUT" + rel[len("results") :] if rel.startswith("results/") else rel
            written.add(_pattern(rel, names))
    listed = documented()
    assert written - listed == set(), "written but not documented"
    assert listed - written == set(), "documented but not written"


def run_script(
    code: str, folder: Path, cache: Path | None = None, timeout: float = 600
) -> subprocess.CompletedProcess:
    """``code`` saved as ``folder/example.py`` and run there with this Python."""
    script = folder / "example.py"
    script.write_text(code)
    env = dict(os.environ, MPLBACKEND="Agg")
    if cache is not None:
        env["OFTIMG_CACHE"] = str(cache)
    return subprocess.run(
        [sys.executable, script.name],
        cwd=folder,
        env=env,
        timeout=timeout,
        capture_output=True,
        text=True,
    )


def test_the_examples_cohort_is_made_once(cache):
    """A second call reuses the cohort (no new folder, nothing left half-made)."""
    before = sorted(p.name for p in cache.iterdir())
    oftimg.example_results(cache)
    assert sorted(p.name for p in cache.iterdir()) == before
    assert len(before) == 1 and before[0].startswith("example-cohort-")


def test_an_older_oftimgs_cohort_is_removed_when_a_new_one_is_made(tmp_path, monkeypatch):
    """The cohort another oftimg made is not reused, and not left behind (the cohort
    itself replaced by a stand-in: making one is what the tests above check)."""
    from oftimg import demos

    older = tmp_path / "example-cohort-0123456789ab" / "results"
    older.mkdir(parents=True)

    def stand_in(out, *args, **kwargs):
        (out / "results").mkdir(parents=True)
        (out / "results" / "run.json").write_text("{}")

    monkeypatch.setattr(demos, "_phantom_cohort", stand_in)
    made = demos.example_results(tmp_path)
    assert (made / "run.json").is_file() and not older.parent.exists()
    assert [p.name for p in tmp_path.iterdir()] == [made.parent.name]


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.stem)
def test_each_example_runs_copied_into_an_empty_folder(example, cache, tmp_path):
    """The reader's way: the page's code in a file of its own, ``python file.py``;
    it ends without an error and leaves nothing beside the script."""
    done = run_script(example.read_text(), tmp_path, cache)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Traceback" not in done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["example.py"]


UNGUARDED = """
from oftimg.workers import make_executor, unguarded_script_line
print("here:", unguarded_script_line())
print("executor:", make_executor(2))
def from_a_function():
    return unguarded_script_line()
print("from a function:", from_a_function())
if __name__ == "__main__":
    print("guarded:", unguarded_script_line())
"""


def test_an_unguarded_script_runs_in_one_process(tmp_path):
    """Called at a script's top level, outside the ``__main__`` guard, oftimg would
    start workers that each run the script again: it names the line, warns and
    runs in this process; under the guard it starts them."""
    done = run_script(UNGUARDED, tmp_path)
    assert done.returncode == 0, done.stderr
    lines = dict(line.split(": ", 1) for line in done.stdout.splitlines())
    assert lines["here"] == f"{tmp_path / 'example.py'}:3"
    assert lines["executor"] == "None"
    assert lines["from a function"] == f"{tmp_path / 'example.py'}:7"  # the line calling it
    assert lines["guarded"] == "None"
    assert (
        f"{tmp_path / 'example.py'}:4: oftimg was called from a script's top level" in done.stderr
    )
    assert "Put the call under that line to use 2 workers" in done.stderr
