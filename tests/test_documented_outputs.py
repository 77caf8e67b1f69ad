"""Every file a run writes is in docs/guide.md's list, and every file listed is written
(issue 54): the list is the documentation's, read from its "Every file a run writes"
block."""
import re
from pathlib import Path

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
    if "figures" in parts[:-1]:      # each figure's PDF and SVG, documented with its PNG
        parts[-1] = re.sub(r"\.(pdf|svg)$", ".png", parts[-1])
    return "/".join(parts)


def test_the_demo_writes_the_documented_files(tmp_path, monkeypatch):
    """The demo's every file (its figures as PNG and PDF), on a smaller cohort: 2 embryos
    per group of 12 frames, enough for the group comparison's tests and figures."""
    from oftimg import api

    monkeypatch.setattr(api, "DEMO_SMALL", (2, {"frames": 12, "vertices_min": 1500,
                                                "vertices_max": 1800}))
    out = api.demo(tmp_path / "demo", quiet=True)
    names = {p.name for p in (out / "data").iterdir()}
    written = set()
    for f in out.rglob("*"):
        if f.is_file() and not any(part.startswith(".") for part in f.relative_to(out).parts):
            rel = f.relative_to(out).as_posix()
            rel = "OUT" + rel[len("results"):] if rel.startswith("results/") else rel
            written.add(_pattern(rel, names))
    listed = documented()
    assert written - listed == set(), "written but not documented"
    assert listed - written == set(), "documented but not written"
