"""An option the command does not have (issue 87, point 7): refused in one line with the
command's own usage and the nearest option it has, exit 2, nothing run."""
import pytest

from oftimg.cli import main


@pytest.mark.parametrize("argv, said", [
    (["run", "data", "--out", "res", "--period_ms", "300"], "did you mean --period-ms?"),
    (["run", "data", "--out", "res", "--feild-smoothing-ms", "30"],
     "did you mean --field-smoothing-ms?"),
    (["phantom", "out", "--zzz"], "(oftimg phantom --help)"),
])
def test_a_mistyped_option_is_named_with_the_nearest_one(tmp_path, capsys, argv, said,
                                                         monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as ended:
        main(argv)
    assert ended.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith(f"oftimg {argv[0]}: error: unrecognized argument")
    assert err[-1].endswith(said) and argv[-2 if argv[-1].isdigit() else -1] in err[-1]
    assert not any(tmp_path.iterdir())                      # nothing written
