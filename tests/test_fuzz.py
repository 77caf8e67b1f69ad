"""Damaged inputs (issue 59): a seeded set of mutations of small phantom datasets,
meshes and label volumes, each given to `oftimg validate` (some to `oftimg run`):
no crash, hang, exception text or raw bytes, one error line and exit 2 for what is
refused, the input unchanged, nothing left beside --out. scripts/fuzz.py runs more."""

import collections

import pytest

from oftimg.cli import main
from oftimg.synthetic.damage import (
    LABEL_MUTATIONS,
    MESH_MUTATIONS,
    base_datasets,
    call_cli,
    fuzz,
    judge,
)


@pytest.mark.slow
def test_damaged_datasets_get_one_clear_line_and_leave_the_input_alone(tmp_path):
    outcomes = fuzz(300, tmp_path, main, seed=0, run_every=60)
    faults = [
        f"case {o.case} {o.base} {o.mutation} ({o.command}, exit {o.exit_code}): "
        f"{'; '.join(o.faults)} | {o.first_line}"
        for o in outcomes
        if o.faults
    ]
    assert not faults, "\n".join(faults)
    # the cases reach what they are meant to: every mutation of both bases, both
    # commands, and mostly damage that must be refused
    done = collections.Counter((o.base, o.mutation.split(":")[0]) for o in outcomes)
    assert set(done) == (
        {("meshes", m.__name__) for m in MESH_MUTATIONS}
        | {("labels", m.__name__) for m in LABEL_MUTATIONS}
    )
    assert {o.command for o in outcomes} == {"validate", "run"}
    refused = sum(o.exit_code == 2 for o in outcomes if o.command == "validate")
    assert refused > 0.75 * 300


def test_the_undamaged_bases_are_valid(tmp_path):
    """What the fuzz damages is valid to begin with (else every refusal is the base's)."""
    for path in base_datasets(tmp_path).values():
        code, stderr, _ = call_cli(main, ["validate", str(path)], 120)
        assert code == 0, stderr


def test_the_judge_finds_each_fault(tmp_path):
    """The fuzz test can fail: each kind of fault is found."""
    (tmp_path / "input").mkdir()
    ok = "oftimg: error: x/f1.ply: file is empty\n"
    assert judge(2, ok, unchanged=True, out=tmp_path / "out") == []
    assert judge(None, "", unchanged=True, out=None) == ["hung"]
    assert judge(-11, "", unchanged=True, out=None) == ["exit -11"]
    assert "exception text" in judge(
        1, "oftimg: internal error: ValueError: x\n", unchanged=True, out=None
    )
    assert "raw bytes on the terminal" in judge(
        2, "oftimg: error: a \x01 b\n", unchanged=True, out=None
    )
    assert judge(2, ok + ok, unchanged=True, out=None) == ["2 error lines"]
    assert judge(2, ok, unchanged=False, out=None) == ["the input was changed"]
    (tmp_path / ".out.finished").mkdir()
    assert judge(2, ok, unchanged=True, out=tmp_path / "out") == ["left behind: .out.finished"]
