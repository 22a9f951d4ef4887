"""YAML read with the line of every key and item, so that a message can name the line.

Needs PyYAML (``pip install "handeye[ros]"``), imported when a file is read.
Mappings come back as :class:`YamlMap` (a ``dict``) and sequences as
:class:`YamlList` (a ``list``), each knowing its own line and the line of each
key or item; scalars are plain Python values (YAML's safe schema: no tags that
build objects). A duplicate key is refused, as the YAML specification says.
Numbers follow :mod:`handeye.core.numbers`: a scalar YAML 1.1 would take for a
number in another form (``0_2``, ``0x10``, ``017`` as octal, ``1:30``, ``1e999``)
is refused naming its line (``017`` reads as 17), and ``1e-05`` reads as a
number, as YAML 1.2 says. ``.nan`` and ``.inf`` read as floats: the readers
refuse them naming the field.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from handeye.core.errors import PoseFileError
from handeye.core.limits import MAX_JSON_DEPTH, check_json_depth
from handeye.core.numbers import OVERFLOW_REASON, number_message, number_problem
from handeye.core.optional import require_package
from handeye.core.textfile import read_text

__all__ = ["YamlList", "YamlMap", "line_of", "load_yaml"]

#: A number of the grammar of :mod:`handeye.core.numbers`; PyYAML's YAML 1.1 takes some of them for strings
#: (``1e-05`` with no dot, ``-2.5e3`` with no exponent sign), YAML 1.2 and every writer for numbers.
_PLAIN_FLOAT = re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?$")


#: YAML's spelling of NaN and infinity: read as floats, for the reader to refuse naming the field.
_YAML_SPECIAL = {".nan": float("nan"), ".inf": float("inf"), "+.inf": float("inf"), "-.inf": float("-inf")}


class _NumberError(Exception):
    """A scalar YAML 1.1 reads as a number, in a form :mod:`handeye.core.numbers` refuses."""

    def __init__(self, message: str, line: int):
        super().__init__(message)
        self.line = line


class YamlMap(dict):
    """A YAML mapping: a ``dict`` with ``line`` (1-based, its first key) and ``key_lines`` (key -> line)."""

    line: int = 0

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.key_lines: dict = {}


class YamlList(list):
    """A YAML sequence: a ``list`` with ``line`` (1-based) and ``item_lines`` (the line of each item)."""

    line: int = 0

    def __init__(self, *args):
        super().__init__(*args)
        self.item_lines: list = []


def line_of(container, key=None) -> int:
    """The 1-based line of ``container[key]`` (a key of a mapping, an index of a sequence), else of the container.

    Returns 0 for a plain value (no line known).
    """
    if isinstance(container, YamlMap) and key in container.key_lines:
        return container.key_lines[key]
    if isinstance(container, YamlList) and isinstance(key, int) and 0 <= key < len(container.item_lines):
        return container.item_lines[key]
    return int(getattr(container, "line", 0))


def _loader(yaml):
    """A safe loader class that builds :class:`YamlMap` and :class:`YamlList`."""

    class LineLoader(yaml.SafeLoader):
        pass

    def mapping(loader, node):
        loader.flatten_mapping(node)
        out = YamlMap()
        out.line = node.start_mark.line + 1
        for key_node, value_node in node.value:
            key = loader.construct_object(key_node, deep=True)
            try:
                duplicate = key in out
            except TypeError:
                raise yaml.constructor.ConstructorError(
                    None, None, "a key that is not a plain value", key_node.start_mark
                ) from None
            if duplicate:
                raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key!r}", key_node.start_mark)
            out[key] = loader.construct_object(value_node, deep=True)
            out.key_lines[key] = key_node.start_mark.line + 1
        return out

    def sequence(loader, node):
        out = YamlList(loader.construct_object(child, deep=True) for child in node.value)
        out.line = node.start_mark.line + 1
        out.item_lines = [child.start_mark.line + 1 for child in node.value]
        return out

    def number(kind: str):
        def construct(loader, node):
            # YAML 1.1 reads 0_2 as 2, 0x10 as 16, 017 as 15 and 1:30 as 90: reread the source text strictly
            text = loader.construct_scalar(node)
            if kind == "float" and text.lower() in _YAML_SPECIAL:  # YAML's own spelling; readers name the field
                return _YAML_SPECIAL[text.lower()]
            if kind == "int" and number_problem(text, integer=True) is None:
                return int(text)
            reason = number_problem(text)  # the message says "not a number": 0_4 may have been meant as 0.4
            if reason is None and math.isfinite(float(text)):
                return float(text)
            raise _NumberError(number_message(text, reason or OVERFLOW_REASON), node.start_mark.line + 1)

        return construct

    LineLoader.add_constructor("tag:yaml.org,2002:map", mapping)
    LineLoader.add_constructor("tag:yaml.org,2002:seq", sequence)
    LineLoader.add_constructor("tag:yaml.org,2002:int", number("int"))
    LineLoader.add_constructor("tag:yaml.org,2002:float", number("float"))
    # YAML 1.1 takes 1e-05 (no dot) for a string; YAML 1.2 and every writer take it for a number
    LineLoader.add_implicit_resolver("tag:yaml.org,2002:float", _PLAIN_FLOAT, list("-+.0123456789"))
    return LineLoader


def load_yaml(path: str | Path, error: type[Exception] = PoseFileError):
    """Read one YAML document, with lines.

    Parameters
    ----------
    path : str or Path
    error : exception class
        Raised with a message naming the file (and the line) when the file is
        missing, not text, not YAML, or holds more than one document.

    Returns
    -------
    YamlMap, YamlList or a plain value
        The document (an empty file gives ``None``).

    Raises
    ------
    error
    MissingDependencyError
        PyYAML is not installed.
    """
    yaml = require_package("yaml", extra="ros", purpose="reading YAML files")
    path = Path(path)
    text = read_text(path, "YAML file", error)
    try:
        docs = [d for d in yaml.load_all(text, Loader=_loader(yaml)) if d is not None]
    except _NumberError as exc:
        raise error(f"{path}, line {exc.line}: {exc}") from None
    except RecursionError:
        raise error(f"{path}: nested deeper than the parser allows (limit {MAX_JSON_DEPTH} levels)") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        where = f", line {mark.line + 1}" if mark is not None else ""
        what = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise error(f"{path}{where}: not valid YAML ({what})") from None
    if len(docs) > 1:
        raise error(f"{path}: holds {len(docs)} YAML documents (separated by '---'); keep one")
    return check_json_depth(docs[0], str(path), error) if docs else None
