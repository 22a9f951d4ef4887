"""The one number grammar of every file handeye reads: what CSV, JSON and YAML writers produce, nothing else.

Python's ``float()`` reads far more than a file should hold: ``float("0_2")`` is 2.0, ``float("２")`` (full
width) and ``float("٢")`` (Arabic-Indic) are 2.0, ``float(" 1 ")`` is 1.0, ``float("nan")`` is NaN, and
``int()`` of a 5,000-digit string stops with a traceback. A number in a user's file is read here instead:

* a number is an optional sign, ASCII digits with an optional fraction, or a fraction alone, and an optional
  exponent: ``[+-]?(\\d+(\\.\\d*)?|\\.\\d+)([eE][+-]?\\d+)?`` (ASCII digits only); an integer is
  ``[+-]?\\d+``;
* at most :data:`MAX_NUMBER_CHARS` characters (float64 needs 24; longer is refused before it is converted);
* no surrounding spaces (a CSV reader strips the spaces around a cell before it calls this), no digit
  separators (``_``), no hexadecimal, no words: ``nan``, ``inf`` and ``infinity`` are refused, as is a
  number beyond float64's range (``1e400``). Every reader refuses a non-finite value anyway, and the tables
  that can hold an unknown value write it as an empty cell, never as ``nan``. Where a format spells NaN
  itself (YAML ``.nan``, OpenCV ``.Nan``, ``NaN`` in a JSON pose file) the reader takes it as NaN and
  refuses it naming the field (``samples[1].robot.translation.x``), which says more than a line number.

:func:`parse_float` and :func:`parse_int` read one cell; :func:`loads_json` parses JSON with the same
rules (the hooks of :func:`json.loads`), so a JSON integer of thousands of digits or a ``NaN`` constant is
refused in one line naming the file and, where it can be told, the line; :func:`float_array` reads a JSON
value that should hold numbers (nested lists of numbers), refusing booleans and checking strings.
"""

from __future__ import annotations

import argparse
import json
import math
import re

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.limits import MAX_JSON_DEPTH, shorten

__all__ = [
    "MAX_NUMBER_CHARS",
    "CSV_CELL_SPACES",
    "NONFINITE_WORDS",
    "OVERFLOW_REASON",
    "NumberError",
    "number_problem",
    "number_message",
    "is_number_text",
    "parse_float",
    "parse_int",
    "parse_floats_fast",
    "loads_json",
    "float_array",
    "as_float",
    "as_int",
    "cli_float",
    "cli_int",
]

#: A number written with more characters than this is refused before it is converted: float64 needs at most
#: 24 (``-2.2250738585072014e-308``); 64 leaves room for zero padding and integers up to 10^63.
MAX_NUMBER_CHARS = 64

#: The spaces a CSV reader strips around a cell before reading its number (``1.0, 2.0`` is common); only these
#: ASCII ones, so that a non-breaking or ideographic space is still refused.
CSV_CELL_SPACES = " \t"

_FLOAT = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_INT = re.compile(r"[+-]?\d+", re.ASCII)
_FLOAT_LINES = re.compile(rf"(?:{_FLOAT.pattern}\n)*{_FLOAT.pattern}", re.ASCII)
#: The words (lower case) that spell NaN or infinity in Python, JSON and YAML: never a number here.
NONFINITE_WORDS = frozenset(
    sign + word for sign in ("", "+", "-") for word in ("nan", "inf", "infinity", ".nan", ".inf")
)


_NONFINITE_REASON = "NaN and infinity are not accepted; an unknown value is left empty where the format allows"


class NumberError(HandEyeInputError):
    """A value that is not a number in the grammar of :mod:`handeye.core.numbers` (the default error)."""


def number_problem(text: str, integer: bool = False) -> str | None:
    """Why ``text`` is not a number of the grammar (``None`` when it is one).

    Parameters
    ----------
    text : str
    integer : bool
        Whether only an integer (``[+-]?\\d+``) is accepted.

    Returns
    -------
    str or None
        A short reason, to follow the value in a message ("is not a number (...)").
    """
    if not isinstance(text, str):
        return f"a {type(text).__name__}, not text"
    if len(text) > MAX_NUMBER_CHARS:
        return f"more than the {MAX_NUMBER_CHARS} characters a number is written with"
    if (_INT if integer else _FLOAT).fullmatch(text):
        return None
    return _grammar_problem(text, integer)


def _grammar_problem(text: str, integer: bool) -> str:
    """Why a text outside the grammar is not a number: the first reason that applies, else the form to write."""
    lower = text.lower()
    reasons = (  # (whether it applies, the reason)
        (text == "", "an empty value"),
        (text != text.strip(), "spaces around it"),
        (lower in NONFINITE_WORDS, _NONFINITE_REASON),
        (integer and _FLOAT.fullmatch(text), "it has a fraction or an exponent"),
        ("_" in text, "'_' digit separators are not read"),
        (any(ch.isdigit() and not "0" <= ch <= "9" for ch in text), "digits other than ASCII 0-9"),
        (lower.lstrip("+-").startswith(("0x", "0o", "0b")), "hexadecimal, octal and binary are not read"),
    )
    form = "write it as 12 or -3" if integer else "write it as 1.5, -2, or 3e-4"
    return next((reason for applies, reason in reasons if applies), form)


def is_number_text(text: str) -> bool:
    """Whether ``text`` is a number :func:`parse_float` reads: the grammar, within float64's range."""
    return number_problem(text) is None and math.isfinite(float(text))


#: The reason given for a number of the grammar that float64 cannot hold (``1e400``).
OVERFLOW_REASON = "beyond the range of a 64-bit float"


def number_message(text: str, reason: str, integer: bool = False) -> str:
    """``"'<text>' is not a number (<reason>)"`` ("an integer", "a finite number" where those fit).

    Parameters
    ----------
    text : str
    reason : str
        From :func:`number_problem`.
    integer : bool

    Returns
    -------
    str
    """
    finite = isinstance(text, str) and (text.lower() in NONFINITE_WORDS or reason == OVERFLOW_REASON)
    noun = "an integer" if integer else "a finite number" if finite else "a number"
    return f"{shorten(text)} is not {noun} ({reason})"


def _fail(text: str, where: str, reason: str, error: type[Exception], integer: bool = False):
    return error(f"{where}: {number_message(text, reason, integer)}")


def parse_float(text: str, where: str, error: type[Exception] = NumberError) -> float:
    """A finite float from ``text`` in the grammar of this module.

    Parameters
    ----------
    text : str
        The value as written (a CSV cell already stripped of the spaces around it).
    where : str
        The file, line or row and column, for the message.
    error : type of Exception
        Raised with one line: ``"<where>: '<text>' is not a number (<reason>)"``.

    Returns
    -------
    float

    Raises
    ------
    error
        Not the grammar, too long, or beyond float64's range.
    """
    reason = number_problem(text)
    if reason is not None:
        raise _fail(text, where, reason, error)
    value = float(text)
    if not math.isfinite(value):
        raise _fail(text, where, OVERFLOW_REASON, error)
    return value


def parse_floats_fast(cells: list[str]) -> np.ndarray | None:
    """The cells as float64 when every one is a finite number of the grammar, else ``None``.

    One regular-expression match over the joined cells instead of one :func:`parse_float` call per cell: a
    pose file of 10^5 rows holds 1.4 million numbers, 4 s one by one. ``None`` tells the caller to read the
    cells one by one with :func:`parse_float`, which names the first bad one.

    Parameters
    ----------
    cells : list of str, length M
        Cells with the CSV spaces already stripped.

    Returns
    -------
    array, shape (M,), or None
    """
    if not cells:
        return np.empty(0)
    joined = "\n".join(cells)
    if max(map(len, cells)) > MAX_NUMBER_CHARS or joined.count("\n") != len(cells) - 1:
        return None  # too long, or a line break inside a cell (a quoted CSV field may hold one)
    if not _FLOAT_LINES.fullmatch(joined):
        return None
    values = np.array(cells, dtype=float)
    return values if np.isfinite(values).all() else None


def parse_int(text: str, where: str, error: type[Exception] = NumberError) -> int:
    """An integer from ``text`` (``[+-]?\\d+``, at most :data:`MAX_NUMBER_CHARS` characters).

    Parameters
    ----------
    text : str
    where : str
    error : type of Exception

    Returns
    -------
    int

    Raises
    ------
    error
    """
    reason = number_problem(text, integer=True)
    if reason is not None:
        raise _fail(text, where, reason, error, integer=True)
    return int(text)


class _JsonNumber(Exception):
    """Raised inside :func:`json.loads` by the number hooks; carries the token and the reason."""

    def __init__(self, token: str, reason: str):
        super().__init__(token)
        self.token, self.reason = token, reason


def _json_float(token: str) -> float:
    if len(token) > MAX_NUMBER_CHARS:
        raise _JsonNumber(token, f"more than the {MAX_NUMBER_CHARS} characters a number is written with")
    value = float(token)
    if not math.isfinite(value):
        raise _JsonNumber(token, OVERFLOW_REASON)
    return value


def _json_int(token: str) -> int:
    if len(token) > MAX_NUMBER_CHARS:
        raise _JsonNumber(token, f"more than the {MAX_NUMBER_CHARS} characters a number is written with")
    return int(token)


def _json_constant(token: str):
    raise _JsonNumber(token, "NaN and Infinity are not JSON numbers; write a number, or null where allowed")


def loads_json(text: str, where: str, error: type[Exception] = NumberError, constants: bool = False):
    """``json.loads`` with the number grammar: long numbers, ``NaN`` and ``Infinity`` refused in one line.

    JSON's own grammar already admits only ASCII digits with no separators; this bounds the length (a
    5,000-digit integer), refuses numbers beyond float64 (``1e400``) and the non-standard constants
    ``NaN``, ``Infinity`` and ``-Infinity`` that Python's parser would accept.

    Parameters
    ----------
    text : str
    where : str
        The file, for the message (the line is added when the number occurs once in the text).
    error : type of Exception
    constants : bool
        Parse ``NaN`` and ``Infinity`` to floats, for a reader that checks every number it takes with
        :func:`float_array` and names the entry (a pose file); by default they are refused here.

    Returns
    -------
    object
        The document.

    Raises
    ------
    error
        A refused number (naming it, and its line where it can be told).
    json.JSONDecodeError, RecursionError
        Not JSON, or nested too deeply: left to the caller, who names the file.
    """
    try:
        hook = float if constants else _json_constant
        return json.loads(text, parse_float=_json_float, parse_int=_json_int, parse_constant=hook)
    except _JsonNumber as exc:
        line = ""
        if text.count(exc.token) == 1:
            line = f", line {text.count(chr(10), 0, text.index(exc.token)) + 1}"
        raise error(f"{where}{line}: {number_message(exc.token, exc.reason)}") from None


def float_array(value, where: str, error: type[Exception] = NumberError) -> np.ndarray:
    """A float64 array of a parsed JSON or YAML value that should hold numbers (a number or nested lists).

    Numbers are taken as they are (booleans refused: ``true`` is not 1.0); a string is read with
    :func:`parse_float` (``"1.5"`` reads, ``"0_2"`` does not), where :func:`numpy.asarray` would take
    ``"0_2"`` and full-width digits.

    Parameters
    ----------
    value : number, str or nested lists of them
    where : str
        The file and entry, for the message.
    error : type of Exception

    Returns
    -------
    array of float64
        The shape of the nested lists (ragged lists raise ``error``).

    Raises
    ------
    error
        A boolean, a string that is not a number, a non-finite number, another type, or ragged lists.
    """

    def convert(v, depth: int):
        if isinstance(v, bool):
            raise error(f"{where}: {v!r} is a boolean, not a number")
        if isinstance(v, (int, float, np.integer, np.floating)):
            if isinstance(v, (int, np.integer)) and abs(int(v)) >= 10**MAX_NUMBER_CHARS:
                raise error(f"{where}: an integer of {len(str(int(v))):,} digits is not a number handeye reads")
            if not math.isfinite(float(v)):
                raise error(f"{where}: {v!r} is not a finite number")
            return float(v)
        if isinstance(v, str):
            return parse_float(v, where, error)
        if isinstance(v, (list, tuple)) and depth < MAX_JSON_DEPTH:
            return [convert(item, depth + 1) for item in v]
        if v is None:
            raise error(f"{where}: null where a number is expected")
        raise error(f"{where}: {shorten(v)} is not a number")

    try:
        return np.array(convert(value, 0), dtype=np.float64)
    except ValueError as exc:
        if isinstance(exc, HandEyeInputError) or isinstance(exc, error):
            raise
        raise error(f"{where}: lists of unequal lengths where a matrix or vector of numbers is expected") from None


def as_float(value, where: str, error: type[Exception] = NumberError) -> float:
    """One finite number of a parsed JSON or YAML document (a number, or a string in the grammar).

    Parameters
    ----------
    value : int, float or str
    where : str
    error : type of Exception

    Returns
    -------
    float

    Raises
    ------
    error
        A boolean, a list, null, a string outside the grammar, a non-finite number.
    """
    out = float_array(value, where, error)
    if out.ndim != 0:
        raise error(f"{where}: a list where one number is expected")
    return float(out)


def as_int(value, where: str, error: type[Exception] = NumberError) -> int:
    """One integer of a parsed JSON or YAML document: an integer, a float with no fraction, or a digit string.

    Parameters
    ----------
    value : int, float or str
    where : str
    error : type of Exception

    Returns
    -------
    int

    Raises
    ------
    error
        A boolean, a fraction (``7.5``: never rounded silently), a string outside ``[+-]?\\d+``, another type.
    """
    if isinstance(value, str):
        return parse_int(value, where, error)
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        if abs(int(value)) >= 10**MAX_NUMBER_CHARS:
            raise error(f"{where}: an integer of {len(str(int(value))):,} digits is not a number handeye reads")
        return int(value)
    number = as_float(value, where, error)
    if not number.is_integer():
        raise error(f"{where}: {number!r} is not a whole number")
    return int(number)


def cli_float(text: str) -> float:
    """argparse ``type=`` for a number option: the grammar of this module (``--x 0_2`` is refused).

    Raises
    ------
    argparse.ArgumentTypeError
        argparse prints it as the option's error (``argument --x: '0_2' is not a number (...)``).
    """
    try:
        return parse_float(text, "")
    except NumberError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix(": ")) from None


def cli_int(text: str) -> int:
    """argparse ``type=`` for an integer option (``[+-]?\\d+``, ASCII digits).

    Raises
    ------
    argparse.ArgumentTypeError
    """
    try:
        return parse_int(text, "")
    except NumberError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix(": ")) from None
