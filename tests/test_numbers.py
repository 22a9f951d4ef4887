"""The number grammar of handeye.core.numbers: what writers produce reads, every other form Python reads is refused."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from handeye.core.errors import HandEyeInputError
from handeye.core.limits import MAX_MESSAGE_CHARS
from handeye.core.numbers import (
    MAX_NUMBER_CHARS,
    NumberError,
    float_array,
    is_number_text,
    loads_json,
    parse_float,
    parse_floats_fast,
    parse_int,
)

ROOT = Path(__file__).resolve().parents[1]

# Each of these Python's float() reads (or raises on with a traceback, for the 5,000 digits); the grammar refuses
# them, with the reason in the message.
REFUSED = {
    "0_2": "'_' digit separators",
    "\uff12": "digits other than ASCII",  # full-width 2
    "\u0662": "digits other than ASCII",  # Arabic-Indic 2
    "1\u0662": "digits other than ASCII",
    "0x1p3": "hexadecimal",
    " 1": "spaces around it",
    "1 ": "spaces around it",
    "1e": "write it as",
    "1.2.3": "write it as",
    "--1": "write it as",
    "9" * 5000: f"more than the {MAX_NUMBER_CHARS} characters",
    "nan": "NaN and infinity are not accepted",
    "-Infinity": "NaN and infinity are not accepted",
    "inf": "NaN and infinity are not accepted",
    "1e400": "beyond the range of a 64-bit float",
    "": "an empty value",
}
ACCEPTED = {
    "0": 0.0,
    "-2": -2.0,
    "+3.5": 3.5,
    "1.": 1.0,
    ".5": 0.5,
    "-2e-3": -0.002,
    "1E+16": 1e16,
    "6.3848318753984534e-01": 0.63848318753984534,  # OpenCV FileStorage
    "-0.4328445609549254": -0.4328445609549254,  # repr of a float64
    "2.2250738585072014e-308": 2.2250738585072014e-308,
}


@pytest.mark.parametrize("text, reason", REFUSED.items(), ids=[repr(t[:12]) for t in REFUSED])
def test_each_form_python_reads_is_refused_with_its_reason(text, reason):
    with pytest.raises(NumberError) as info:
        parse_float(text, "f.csv, line 3, column x")
    message = str(info.value)
    assert message.startswith("f.csv, line 3, column x: ") and reason in message
    assert "\n" not in message and len(message) <= MAX_MESSAGE_CHARS
    assert not is_number_text(text)


@pytest.mark.parametrize("text, value", ACCEPTED.items())
def test_plain_decimal_and_scientific_forms_read_exactly_as_float_reads_them(text, value):
    assert parse_float(text, "here") == value == float(text)
    assert is_number_text(text)


def test_the_fast_path_reads_what_parse_float_reads_and_nothing_else():
    good = list(ACCEPTED)
    assert parse_floats_fast(good).tolist() == [parse_float(t, "here") for t in good]
    for bad in REFUSED:  # one bad cell among good ones sends the caller to the cell-by-cell reading
        assert parse_floats_fast(good + [bad] + good) is None, repr(bad[:12])
    assert parse_floats_fast(["1\n2"]) is None  # a line break inside a cell is not two numbers


def test_integers_refuse_fractions_and_long_digits():
    assert parse_int("-17", "here") == -17
    assert parse_int("9" * MAX_NUMBER_CHARS, "here") == int("9" * MAX_NUMBER_CHARS)
    for text, reason in [("0.5", "fraction"), ("1e3", "fraction or an exponent"), ("0_2", "'_'"), ("\uff12", "ASCII")]:
        with pytest.raises(NumberError, match=f"is not an integer .*{reason}"):
            parse_int(text, "here")
    with pytest.raises(NumberError, match="more than the 64 characters"):
        parse_int("9" * (MAX_NUMBER_CHARS + 1), "here")


def test_the_error_class_is_the_callers():
    class MyError(HandEyeInputError):
        pass

    with pytest.raises(MyError, match="row 2: '0_2'"):
        parse_float("0_2", "row 2", MyError)


def test_json_refuses_long_integers_and_constants_naming_the_line():
    with pytest.raises(NumberError, match=r"x\.json, line 3: '9999.*5,000 characters"):
        loads_json('{\n "a": 1,\n "b": ' + "9" * 5000 + "\n}", "x.json")
    for constant in ("NaN", "Infinity", "-Infinity"):
        with pytest.raises(NumberError, match=f"x.json, line 2: '{constant}' is not a finite number"):
            loads_json('{"a":\n ' + constant + "}", "x.json")
    with pytest.raises(NumberError, match="'1e400' is not a finite number"):
        loads_json("[1e400]", "x.json")
    # the same token twice: the file is named, no line guessed
    with pytest.raises(NumberError, match=r"^x\.json: 'NaN'"):
        loads_json('{"NaN": NaN}', "x.json")
    assert loads_json('{"a": [1, -2.5e-3, 0]}', "x.json") == {"a": [1, -0.0025, 0]}
    assert np.isnan(loads_json("[NaN]", "x.json", constants=True)[0])  # for a reader that names the entry


def test_float_array_checks_each_value():
    np.testing.assert_array_equal(float_array([[1, 2.5], ["3", "-4e1"]], "m"), [[1.0, 2.5], [3.0, -40.0]])
    for value, message in [
        ([1, True], "boolean"),
        (["0_2"], "'_' digit separators"),
        (["\uff12"], "ASCII"),
        ([1, None], "null"),
        ([1, float("nan")], "not a finite number"),
        ([[1, 2], [3]], "unequal lengths"),
        ([10**70], "digits is not a number"),
        ({"a": 1}, "is not a number"),
    ]:
        with pytest.raises(NumberError, match=message):
            float_array(value, "m")


def _numbers_of(path: Path) -> list[str]:
    """The tokens of a shipped file that Python's float() reads as numbers."""
    if path.suffix == ".json":
        tokens = []
        json.loads(path.read_text(), parse_float=tokens.append, parse_int=tokens.append)
        return tokens
    text = "\n".join(line for line in path.read_text().splitlines() if not line.lstrip().startswith("#"))
    out = []
    for row in csv.reader(text.splitlines()):
        for cell in row:
            try:
                float(cell)
            except ValueError:
                continue
            out.append(cell.strip(" \t"))
    return out


@pytest.mark.parametrize("name", ["example_eye_to_hand.csv", "example_eye_to_hand_truth.json"])
def test_every_number_of_the_shipped_examples_is_in_the_grammar(name):
    tokens = _numbers_of(ROOT / "handeye" / "data" / name)
    assert len(tokens) >= 16
    assert [t for t in tokens if not is_number_text(t)] == []


def test_command_line_types_refuse_what_argparse_float_takes():
    import argparse

    from handeye.core.numbers import cli_float, cli_int

    parser = argparse.ArgumentParser(exit_on_error=False)
    parser.add_argument("--x", type=cli_float)
    parser.add_argument("--n", type=cli_int)
    assert parser.parse_args(["--x=-2.5e-3", "--n", "7"]) == argparse.Namespace(x=-0.0025, n=7)
    for option, text, reason in [("--x", "0_2", "'_'"), ("--x", "nan", "NaN"), ("--n", "\u0667", "ASCII")]:
        with pytest.raises(argparse.ArgumentError, match=f"{option}: '{text}' is not .*{reason}"):
            parser.parse_args([option, text])
