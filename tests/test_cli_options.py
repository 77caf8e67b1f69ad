"""An option the command does not have (issue 87, point 7): refused in one line with the
command's own usage and the nearest option it has, exit 2, nothing run."""

import pytest

from oftimg.cli import main


@pytest.mark.parametrize(
    "argv, said",
    [
        (["run", "data", "--out", "res", "--period_ms", "300"], "did you mean --period-ms?"),
        (
            ["run", "data", "--out", "res", "--feild-smoothing-ms", "30"],
            "did you mean --field-smoothing-ms?",
        ),
        (["phantom", "out", "--zzz"], "(oftimg phantom --help)"),
    ],
)
def test_a_mistyped_option_is_named_with_the_nearest_one(tmp_path, capsys, argv, said, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as ended:
        main(argv)
    assert ended.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith(f"oftimg {argv[0]}: error: unrecognized argument")
    assert err[-1].endswith(said) and argv[-2 if argv[-1].isdigit() else -1] in err[-1]
    assert not any(tmp_path.iterdir())  # nothing written


def test_run_help_is_grouped_with_examples_and_every_option_says_what_it_does(capsys):
    """Issue 87: run --help in groups (input, analysis, outputs, performance) ending with
    examples; demo and animate say what they do and every option has help."""
    from oftimg.cli import _parser

    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = capsys.readouterr().out
    headings = [
        line for line in text.splitlines() if line.endswith(":") and not line.startswith(" ")
    ]
    assert headings[-5:] == ["input:", "analysis:", "outputs:", "performance:", "examples:"]
    assert "oftimg run cohort --out results --resume" in text
    sub = next(a for a in _parser()._actions if a.dest == "command")
    for name in ("demo", "animate", "run"):
        command = sub.choices[name]
        assert command.description, name
        for action in command._actions:
            assert action.help, f"{name} {action.option_strings or action.dest}"


def test_the_docs_show_run_examples_as_a_literal_block():
    """docs/cli.rst reads each epilog as reStructuredText: the examples' columns go in a
    plain-text block there, while --help prints them as they are."""
    from oftimg.cli import RUN_EXAMPLES, _parser, _parser_for_docs

    def run_parser(p):
        return next(a for a in p._actions if a.dest == "command").choices["run"]

    assert run_parser(_parser()).epilog == RUN_EXAMPLES
    head, block = run_parser(_parser_for_docs()).epilog.split("\n\n.. code-block:: text\n\n")
    assert head == RUN_EXAMPLES.splitlines()[0]
    lines = block.splitlines()
    assert [line[2:] for line in lines] == RUN_EXAMPLES.splitlines()[1:]
    assert all(line.startswith("  ") for line in lines if line)
