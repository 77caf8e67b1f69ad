"""Input files opened safely: only regular files (a FIFO, a device or a folder given
as a file is refused before it is opened, so nothing blocks or reads without end),
sizes bounded before a byte is read, and JSON with its depth and numbers bounded.

Every refusal is a :class:`~oftimg.errors.DatasetError` that names the file.
"""

from __future__ import annotations

import errno
import json
import os
import re
import stat
from pathlib import Path

import numpy as np

from ..errors import DatasetError

JSON_MAX_BYTES = 1 << 20  # a meta.json of 1 MiB is not a meta.json
JSON_MAX_DEPTH = 8
JSON_MAX_DIGITS = 15  # whole numbers beyond 10^15 are no voxel, period or label

_KINDS = {
    stat.S_IFDIR: "a folder",
    stat.S_IFIFO: "a named pipe (FIFO)",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
}


def file_status(path: Path, *, optional: bool = False) -> os.stat_result | None:
    """The status of a regular file at ``path`` (links followed), or the error that
    says what else it is. With ``optional``, None where nothing is there at all
    (not for a broken link or a link loop: the user meant a file there)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        if os.path.islink(path):
            raise DatasetError(f"{path}: a broken link (its target does not exist)") from None
        if optional:
            return None
        raise DatasetError(f"{path}: file not found") from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise DatasetError(f"{path}: a loop of symbolic links") from None
        raise DatasetError(f"{path}: cannot be read ({exc.strerror})") from None
    if not stat.S_ISREG(st.st_mode):
        kind = _KINDS.get(stat.S_IFMT(st.st_mode), "not a regular file")
        raise DatasetError(f"{path}: is {kind}, not a file")
    return st


def read_regular_file(path: Path, *, max_bytes: int) -> bytes:
    """The whole content of a regular, non-empty file of at most ``max_bytes``
    (0: check the file only, read nothing)."""
    st = file_status(path)
    if st.st_size == 0:
        raise DatasetError(f"{path}: file is empty")
    if max_bytes == 0:
        return b""
    if st.st_size > max_bytes:
        raise DatasetError(
            f"{path}: {st.st_size / 2**20:.0f} MiB, more than the "
            f"{max_bytes / 2**20:.0f} MiB such a file can be"
        )
    # O_NONBLOCK: had the file become a FIFO since the check, open would not block
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    try:
        with os.fdopen(fd, "rb") as fh:
            return fh.read(max_bytes + 1)
    except OSError as exc:
        raise DatasetError(f"{path}: cannot be read ({exc.strerror})") from None


def read_file_start(path: Path, n_bytes: int) -> bytes:
    """The first ``n_bytes`` (or fewer) of a regular file: enough to look at a header
    without reading a whole mesh."""
    file_status(path)
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    try:
        with os.fdopen(fd, "rb") as fh:
            return fh.read(n_bytes)
    except OSError as exc:
        raise DatasetError(f"{path}: cannot be read ({exc.strerror})") from None


def _bounded_int(text: str) -> int:
    if len(text.lstrip("-")) > JSON_MAX_DIGITS:
        raise ValueError(f"a whole number of {len(text.lstrip('-'))} digits")
    return int(text)


def _no_constant(name: str):
    raise ValueError(f"{name}, which JSON does not have")


def read_json_file(path: Path, *, optional: bool = False) -> object | None:
    """A small JSON file's value: at most 1 MiB, nested at most 8 deep, whole numbers
    of at most 15 digits, no NaN or Infinity. None where ``optional`` and absent."""
    if file_status(path, optional=optional) is None:
        return None
    data = read_regular_file(path, max_bytes=JSON_MAX_BYTES)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise DatasetError(f"{path}: not valid JSON (not UTF-8 text)") from None
    bare = re.sub(r'"(?:[^"\\]|\\.)*"', '""', text)  # brackets inside strings
    depth = np.cumsum(_bracket_steps(bare))
    if depth.size and depth.max() > JSON_MAX_DEPTH:
        raise DatasetError(
            f"{path}: not valid JSON for oftimg (nested {int(depth.max())} "
            f"deep; at most {JSON_MAX_DEPTH})"
        )
    try:
        return json.loads(text, parse_int=_bounded_int, parse_constant=_no_constant)
    except json.JSONDecodeError as exc:
        raise DatasetError(
            f"{path}: not valid JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})"
        ) from None
    except ValueError as exc:
        raise DatasetError(f"{path}: not valid JSON for oftimg ({exc})") from None


def _bracket_steps(text: str) -> np.ndarray:
    """+1 for each opening bracket, -1 for each closing one, in order."""
    codes = np.frombuffer(text.encode("utf-8", "replace"), np.uint8)
    return np.isin(codes, (ord("["), ord("{"))).astype(np.int32) - np.isin(
        codes, (ord("]"), ord("}"))
    ).astype(np.int32)
