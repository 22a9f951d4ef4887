"""OpenCV FileStorage YAML (``%YAML:1.0``, ``!!opencv-matrix``) read without OpenCV, with lines.

``cv2.FileStorage`` writes a YAML subset that PyYAML refuses (the header
``%YAML:1.0`` is not YAML 1.1's ``%YAML 1.1``)::

    %YAML:1.0
    ---
    frameCount: 42
    T1_0: !!opencv-matrix
       rows: 4
       cols: 4
       dt: d
       data: [ 6.3848318753984534e-01, 7.6753379672568189e-01,
           5.6842678621069898e-02, ... 0., 0., 0., 1. ]
    name: "a string"
    nested:
       key: 1.5
    list: [ 1, 2, 3 ]
    other:
       - 1
       - 2

This module reads that subset with the standard library and numpy, so that the
pose path (:mod:`handeye.core.opencv_pose_pairs`) needs no OpenCV: block
mappings by indentation, block sequences of ``- `` items, flow sequences
``[ ... ]`` over any number of lines, one-line flow mappings ``{ k: v }``,
plain and quoted scalars, OpenCV's ``.Nan``/``.Inf``, ``#`` comments, and
``!!opencv-matrix`` mappings (``rows``, ``cols``, ``dt``, ``data``), which come
back as float arrays of shape ``(rows, cols)``. Mappings come back as
:class:`~handeye.core.yamlfile.YamlMap` and sequences as
:class:`~handeye.core.yamlfile.YamlList`, each knowing the line of every key
and item, as :func:`handeye.core.yamlfile.load_yaml` returns them. Anything
outside the subset is refused with the file and the line.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from handeye.core.errors import PoseFileError
from handeye.core.limits import MAX_JSON_DEPTH, shorten
from handeye.core.numbers import number_problem
from handeye.core.textfile import read_text
from handeye.core.yamlfile import YamlList, YamlMap

__all__ = ["OPENCV_YAML_HEADER", "is_opencv_yaml", "load_opencv_yaml", "parse_opencv_yaml"]

#: The first line of every FileStorage YAML file (OpenCV 2.x to 4.x).
OPENCV_YAML_HEADER = "%YAML:1.0"
#: ``dt`` codes of an ``!!opencv-matrix`` whose elements are numbers this reader takes (OpenCV's depth codes).
_MATRIX_DTYPES = ("u", "c", "w", "s", "i", "f", "d")
#: The spaces YAML separates with (ASCII only: a no-break or ideographic space beside a number is no separator,
#: and the number it touches is refused, where Python's str.strip would drop it silently).
_SPACES = " \t\r\n"
_KEY = re.compile(r"^([A-Za-z_][\w.\-]*|\"[^\"]*\"|'[^']*')[ \t]*:(?:[ \t]+|$)(.*)$")
_SPECIAL = {".nan": np.nan, ".inf": np.inf, "+.inf": np.inf, "-.inf": -np.inf}


def is_opencv_yaml(path: str | Path) -> bool:
    """Whether the file's first line is OpenCV's ``%YAML:1.0`` (or ``%YAML 1.0``) header.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bool
        False also for a file that cannot be read (its reader then says why).
    """
    try:
        with open(path, "rb") as f:
            head = f.read(64).decode("utf-8-sig", errors="replace").lstrip(_SPACES)
    except OSError:
        return False
    return head.startswith(("%YAML:1.", "%YAML 1.0"))


def _strip_comment(text: str) -> str:
    """The line without a ``#`` comment (a ``#`` inside quotes is kept)."""
    quote = None
    for k, ch in enumerate(text):
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch == "#" and (k == 0 or text[k - 1].isspace()):
            return text[:k]
    return text


def _scalar(text: str):
    """A plain or quoted scalar: int, float (``.Nan``, ``.Inf`` too) or str.

    Numbers follow :mod:`handeye.core.numbers`; anything else (``0_2``, full-width digits, ``1e400``, 5,000
    digits) stays a string, which a matrix's ``data`` and the readers refuse as "not a number" with its line.
    ``.Nan`` and ``.Inf`` are OpenCV's own spelling and read as floats; every reader refuses them as non-finite.
    """
    text = text.strip(_SPACES)
    if len(text) >= 2 and text[0] == text[-1] and text[0] in "\"'":
        return text[1:-1]
    low = text.lower()
    if low in _SPECIAL:
        return _SPECIAL[low]
    if number_problem(text, integer=True) is None:
        return int(text)
    if number_problem(text) is None and np.isfinite(float(text)):
        return float(text)
    return text  # not a number of handeye.core.numbers (0_2, full-width digits, 1e400): a string


def _split_flow(body: str) -> list[str]:
    """The comma-separated items of a flow collection's inside (no nesting in OpenCV's subset)."""
    items = [item.strip(_SPACES) for item in body.split(",")]
    if items and items[-1] == "":
        items.pop()  # a trailing comma
    return items


class _Parser:
    def __init__(self, text: str, source: str, error: type[Exception]):
        self.source, self.error = source, error
        self.lines: list[tuple[int, int, str]] = []  # (line number, indent, content)
        for number, line in enumerate(text.splitlines(), start=1):
            if "\t" in line[: len(line) - len(line.lstrip(_SPACES))]:
                raise self.fail(number, "a tab in the indentation (YAML indents with spaces)")
            content = _strip_comment(line.lstrip("\ufeff")).rstrip(_SPACES)
            if not content.strip(_SPACES) or content.strip(_SPACES) in ("---", "..."):
                continue
            if content.startswith("%YAML") and not self.lines:
                continue  # the header
            if content.startswith("%"):
                raise self.fail(number, f"directive {shorten(content.strip(_SPACES))} after the first line")
            self.lines.append((number, len(content) - len(content.lstrip(_SPACES)), content.strip(_SPACES)))
        self.pos = 0

    def fail(self, line: int, message: str) -> Exception:
        return self.error(f"{self.source}, line {line}: {message}")

    def parse(self):
        if not self.lines:
            return YamlMap()
        number, indent, _ = self.lines[0]
        if indent != 0:
            raise self.fail(number, "the first key is indented")
        doc = self.block(0, 0)
        if self.pos < len(self.lines):
            raise self.fail(self.lines[self.pos][0], "indented less than its mapping, or a second top-level node")
        return doc

    def block(self, indent: int, depth: int):
        """The mapping or sequence whose lines start at ``indent``."""
        if depth > MAX_JSON_DEPTH:
            raise self.fail(self.lines[self.pos][0], f"nested deeper than {MAX_JSON_DEPTH} levels")
        if self.lines[self.pos][2].startswith("- ") or self.lines[self.pos][2] == "-":
            return self.sequence(indent, depth)
        return self.mapping(indent, depth)

    def mapping(self, indent: int, depth: int) -> YamlMap:
        out = YamlMap()
        out.line = self.lines[self.pos][0]
        while self.pos < len(self.lines):
            number, ind, content = self.lines[self.pos]
            if ind < indent:
                break
            if ind > indent:
                raise self.fail(number, f"indented more than the keys above it: {shorten(content)}")
            found = _KEY.match(content)
            if found is None:
                raise self.fail(number, f"expected 'key: value', got {shorten(content)}")
            key, rest = _scalar(found.group(1)), found.group(2).strip(_SPACES)
            if key in out:
                raise self.fail(number, f"duplicate key {key!r}")
            self.pos += 1
            out[key] = self.value(rest, number, indent, depth, key)
            out.key_lines[key] = number
        return out

    def sequence(self, indent: int, depth: int) -> YamlList:
        out = YamlList()
        out.line = self.lines[self.pos][0]
        while self.pos < len(self.lines):
            number, ind, content = self.lines[self.pos]
            if ind < indent:
                break
            if ind > indent or not (content.startswith("- ") or content == "-"):
                raise self.fail(number, f"expected a '- ' item of the sequence, got {shorten(content)}")
            self.pos += 1
            rest = content[1:].strip(_SPACES)
            if _KEY.match(rest):
                raise self.fail(number, "a mapping inside a sequence item: outside the FileStorage subset read here")
            out.append(self.value(rest, number, indent, depth, len(out)))
            out.item_lines.append(number)
        return out

    def value(self, rest: str, number: int, indent: int, depth: int, key):
        """The value after ``key:`` (``rest``), reading continuation lines as needed."""
        tag = None
        if rest.startswith("!!"):
            tag, _, rest = rest.partition(" ")
            rest = rest.strip(_SPACES)
        if rest.startswith("["):
            node = self.flow_sequence(rest, number)
        elif rest.startswith("{"):
            node = self.flow_mapping(rest, number)
        elif rest:
            node = _scalar(rest)
        elif self.pos < len(self.lines) and self.lines[self.pos][1] > indent:
            node = self.block(self.lines[self.pos][1], depth + 1)
        elif self.pos < len(self.lines) and self.lines[self.pos][1] == indent and self.lines[self.pos][2][:1] == "-":
            node = self.sequence(indent, depth + 1)  # a sequence may sit at its key's indent
        else:
            node = None
        if tag == "!!opencv-matrix":
            return self.matrix(node, number, key)
        if tag is not None and tag not in ("!!str", "!!float", "!!int", "!!map", "!!seq"):
            raise self.fail(number, f"{key}: tag {tag} is outside the FileStorage subset read here")
        return node

    def flow_sequence(self, rest: str, number: int) -> YamlList:
        text = rest
        while "]" not in text:
            if self.pos >= len(self.lines) or _KEY.match(self.lines[self.pos][2]):
                raise self.fail(number, "a '[' list that is never closed with ']'")
            text += " " + self.lines[self.pos][2]
            self.pos += 1
        body, _, tail = text[1:].partition("]")
        if tail.strip(_SPACES):
            raise self.fail(number, f"text after the list's ']': {shorten(tail.strip(_SPACES))}")
        if "[" in body or "{" in body:
            raise self.fail(number, "a nested list or mapping inside '[ ]': outside the FileStorage subset read here")
        out = YamlList(_scalar(item) for item in _split_flow(body))
        out.line = number
        out.item_lines = [number] * len(out)
        return out

    def flow_mapping(self, rest: str, number: int) -> YamlMap:
        if not rest.endswith("}") or rest.count("{") != 1:
            raise self.fail(number, "a '{ }' mapping must open and close on one line, without nesting")
        out = YamlMap()
        out.line = number
        for item in _split_flow(rest[1:-1]):
            key, sep, value = item.partition(":")
            if not sep:
                raise self.fail(number, f"expected 'key: value' inside '{{ }}', got {shorten(item)}")
            out[_scalar(key)] = _scalar(value)
            out.key_lines[_scalar(key)] = number
        return out

    def matrix(self, node, number: int, key) -> np.ndarray:
        """An ``!!opencv-matrix`` mapping as a float array ``(rows, cols)``, or an error naming the key."""
        if not isinstance(node, dict):
            raise self.fail(number, f"{key}: an !!opencv-matrix must be a mapping of rows, cols, dt and data")
        missing = [k for k in ("rows", "cols", "dt", "data") if k not in node]
        if missing:
            raise self.fail(number, f"{key}: the !!opencv-matrix has no {', '.join(missing)}")
        rows, cols, dt, data = node["rows"], node["cols"], node["dt"], node["data"]
        if not (isinstance(rows, int) and isinstance(cols, int) and rows >= 0 and cols >= 0):
            raise self.fail(number, f"{key}: rows and cols must be whole numbers, got {rows!r} and {cols!r}")
        if str(dt) not in _MATRIX_DTYPES:
            raise self.fail(number, f"{key}: dt {dt!r} is not a one-channel number type ({', '.join(_MATRIX_DTYPES)})")
        if not isinstance(data, list):
            raise self.fail(number, f"{key}: data must be a '[ ... ]' list of numbers")
        bad = [v for v in data if isinstance(v, str)]
        if bad:
            raise self.fail(number, f"{key}: data holds {shorten(bad[0])}, not a number")
        if len(data) != rows * cols:
            raise self.fail(
                number, f"{key}: rows x cols = {rows} x {cols} = {rows * cols}, but data holds {len(data)} numbers"
            )
        return np.asarray(data, dtype=float).reshape(rows, cols)


def parse_opencv_yaml(text: str, source: str = "<text>", error: type[Exception] = PoseFileError) -> YamlMap:
    """Parse FileStorage YAML text (the subset in this module's docstring).

    Parameters
    ----------
    text : str
    source : str
        Named in messages (the file's path).
    error : exception class
        Raised with ``"<source>, line <n>: <cause>"``.

    Returns
    -------
    YamlMap
        The top-level mapping; ``!!opencv-matrix`` values as float arrays ``(rows, cols)``.

    Raises
    ------
    error
    """
    doc = _Parser(text, source, error).parse()
    if not isinstance(doc, YamlMap):
        raise error(f"{source}: the top level is a sequence; FileStorage YAML holds a mapping of named nodes")
    return doc


def load_opencv_yaml(path: str | Path, error: type[Exception] = PoseFileError) -> YamlMap:
    """Read a FileStorage YAML file (first line ``%YAML:1.0``).

    Parameters
    ----------
    path : str or Path
    error : exception class
        Raised naming the file (and line): missing, too large, not UTF-8 text, no ``%YAML`` header, outside
        the subset.

    Returns
    -------
    YamlMap
        As :func:`parse_opencv_yaml`.

    Raises
    ------
    error
    """
    path = Path(path)
    text = read_text(path, "YAML file", error)
    if not text.lstrip(_SPACES).startswith("%YAML"):
        raise error(f"{path}, line 1: no '{OPENCV_YAML_HEADER}' header; not an OpenCV FileStorage YAML file")
    return parse_opencv_yaml(text, str(path), error)
