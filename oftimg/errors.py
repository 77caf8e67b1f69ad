"""What oftimg raises for its users' mistakes (the CLI's exit status 2).

A ``ValueError``, as the conventions ask; the CLI tells it apart from a
``ValueError`` or ``TypeError`` out of a library, which is oftimg's own
failure (exit status 1, "internal error"), not bad input.
"""


class InputError(ValueError):
    """Bad input or a bad option: the message names it, what was expected and
    what was found."""


class DatasetError(InputError):
    """Bad input data: the message names the file and the problem; ``problems``, where
    several files were checked, each bad file and its own message."""

    problems: list[tuple] = []


class OftimgWarning(UserWarning):
    """Something oftimg repaired or assumed; the run goes on."""
