"""The rooms of the house, measured: long functions, long parameter lists, branching, private imports, tolerances.

Run from the repository root::

    python benchmarks/code_measures.py                          # the working tree
    python benchmarks/code_measures.py --before 0cd7060          # a commit beside it, as "before -> after"
    python benchmarks/code_measures.py --before 0cd7060 --out benchmarks/results/code_measures.md

Measured over the packages (``handeye/``, ``classic/``, ``sim/``, ``learned/``); the tolerances over ``tests/``.
A commit is read with ``git archive`` into a temporary folder, never checked out. What each row counts:

- *lines*: non-blank lines of Python, in all and per package;
- *functions over 60 and over 100 lines*: from ``def`` to the function's last line, docstring included (nested
  functions count on their own);
- *functions with 8+ parameters*: positional, keyword-only and ``*args`` / ``**kwargs`` each count one;
  ``self`` and ``cls`` do not;
- *complexity over 10*: radon's cyclomatic complexity (McCabe) of each function and method, as
  ``radon cc`` reports it;
- *private imports across modules*: uses of another project module's private names or private modules,
  lazy imports and ``module._name`` included (:func:`private_imports`, the definition that
  ``tests/test_private_imports.py`` holds the tree to);
- *literal tolerances in tests*: ``atol=``, ``rtol=``, ``abs=``, ``rel=`` given a number written in the test
  (not a name from ``tests/tolerances.py``), outside ``tests/tolerances.py``.

- *pairs of repeated blocks*: the pairs of places in the packages (the four together, nothing else) that share
  six or more lines, the same or of the same shape, as the workplace's ``duplicates`` tool counts them (its
  first line); "not measured" where the tool is not on the ``PATH``.

The test suite's wall time is CI's: quoted in the CHANGELOG beside these.
"""

from __future__ import annotations

import argparse
import ast
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
from io import BytesIO
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._report import Report  # noqa: E402

PACKAGES = ("handeye", "classic", "sim", "learned")
#: The roots whose modules' private names are private to them (:func:`private_imports`).
PROJECT = (*PACKAGES, "benchmarks")
TOLERANCE_KEYWORDS = ("atol", "rtol", "abs", "rel")
LONG_LINES = 100
FAIRLY_LONG_LINES = 60
MANY_PARAMETERS = 8
COMPLEX = 10


def _files(root: Path, folders) -> list[Path]:
    return sorted(p for folder in folders for p in (root / folder).rglob("*.py"))


def _module(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _functions(tree: ast.AST):
    return [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]


def parameter_count(fn: ast.FunctionDef) -> int:
    """Parameters of a ``def``: positional, keyword-only, ``*args`` and ``**kwargs``; not ``self`` / ``cls``."""
    a = fn.args
    names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
    names += [x.arg for x in (a.vararg, a.kwarg) if x is not None]
    return len([n for n in names if n not in ("self", "cls")])


def _private(name: str) -> bool:
    """A name with one leading underscore (dunders such as ``__version__`` are public)."""
    return name.startswith("_") and not name.startswith("__")


def _through_private_module(target: str, own: str) -> bool:
    """Whether ``target`` passes through a private module (``P._mod``) whose package ``P`` does not hold ``own``."""
    parts = target.split(".")
    for i, part in enumerate(parts):
        package = ".".join(parts[:i])
        if i and _private(part) and not (own == package or own.startswith(package + ".")):
            return True
    return False


def _dotted(node: ast.expr) -> str | None:
    """``a.b.c`` of an attribute chain on a name, else None."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        base = _dotted(node.value)
        return None if base is None else f"{base}.{node.attr}"
    return None


def private_imports(root: Path, path: Path, modules: set) -> list[tuple[int, str]]:
    """``(line, dotted name)`` of every private name of another project module that ``path`` uses.

    The one definition of a private import (``tests/test_private_imports.py`` holds the tree to it):

    - ``from M import _name`` where ``M`` is another project module (relative imports resolved);
    - ``M._name`` where ``M`` is bound in the file to another project module (``import M``, ``import M as m``,
      ``from pkg import M``; dotted chains such as ``classic.shah._shah`` too);
    - ``from P._mod import name`` / ``import P._mod`` from outside the package ``P``.

    Allowed: a module's own names, a package's ``__init__`` importing its own modules' private names (a
    re-export), a private module imported inside its own package. Lazy imports inside functions count.

    Parameters
    ----------
    root : Path
        The repository's root (module names are dotted paths below it).
    path : Path
        A project file under ``root``.
    modules : set of str
        The project's dotted module names.

    Returns
    -------
    list of (int, str)
    """
    own = _module(root, path)
    package = own.split(".") if path.name == "__init__.py" else own.split(".")[:-1]
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found, aliases = [], {}  # local name -> the project module it is bound to

    def check(line: int, target: str, name: str | None) -> None:
        if target == own:
            return
        full = f"{target}.{name}" if name else target
        if full in modules:  # a module: private to its package only
            bad = _through_private_module(full, own)
        else:
            reexport = path.name == "__init__.py" and target.startswith(own + ".")
            bad = _through_private_module(target, own) or (name is not None and _private(name) and not reexport)
        if bad:
            found.append((line, full))

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in PROJECT:
                    check(node.lineno, a.name, None)
                    # `import a.b` binds `a` (the chain resolves below), `import a.b as m` binds `m`
                    aliases[a.asname or a.name.split(".")[0]] = a.name if a.asname else a.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            mod = ".".join(base + ([node.module] if node.module else []))
            if mod.split(".")[0] not in PROJECT:
                continue
            for a in node.names:
                check(node.lineno, mod, a.name)
                if f"{mod}.{a.name}" in modules:
                    aliases[a.asname or a.name] = f"{mod}.{a.name}"
    for node in ast.walk(tree):  # a second pass: a lazy import may come after a use in the walk's order
        if not (isinstance(node, ast.Attribute) and _private(node.attr)):
            continue
        head, _, rest = (_dotted(node.value) or "").partition(".")
        if head not in aliases:
            continue
        target = aliases[head] + (f".{rest}" if rest else "")
        if target in modules and target != own:
            found.append((node.lineno, f"{target}.{node.attr}"))
    return found


def literal_tolerances(tree: ast.AST) -> int:
    """Keyword arguments ``atol`` / ``rtol`` / ``abs`` / ``rel`` given a number literal (a sign allowed)."""
    count = 0
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            for kw in node.keywords:
                value = kw.value.operand if isinstance(kw.value, ast.UnaryOp) else kw.value
                if kw.arg in TOLERANCE_KEYWORDS and isinstance(value, ast.Constant):
                    count += isinstance(value.value, (int, float)) and not isinstance(value.value, bool)
    return count


def complexities(source: str) -> list[tuple[str, int]] | None:
    """``(name, radon complexity)`` of every function and method; None without radon."""
    try:
        from radon.complexity import cc_visit
    except ImportError:
        return None
    out = []
    for block in cc_visit(source):
        out.append((block.fullname, block.complexity))
        out += [(f"{block.name}.{m.name}", m.complexity) for m in getattr(block, "methods", ())]
    return [(name, c) for name, c in out if not name.startswith("<")]


def repeated_pairs(root: Path) -> int | str:
    """Pairs of places in the packages under ``root`` sharing six or more lines (the ``duplicates`` tool's
    count, over a copy of the four packages' Python files alone); "not measured" without the tool."""
    tool = shutil.which("duplicates")
    if tool is None:
        return "not measured"
    with tempfile.TemporaryDirectory() as tmp:
        for path in _files(root, PACKAGES):
            target = Path(tmp) / path.relative_to(root)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)
        out = subprocess.run([tool, "--repo", tmp, "--most", "1", "--seconds", "120"], capture_output=True, text=True)
    first = out.stdout.splitlines()[0] if out.stdout else ""
    found = re.match(r"(\d+) pairs", first)
    return int(found.group(1)) if found else 0 if first.startswith("no duplicates") else f"unread: {first!r}"


def measure(root: Path) -> dict:
    """The measures of a tree (see the module's docstring); ``longest`` lists the ten longest functions."""
    files = _files(root, PACKAGES)
    modules = {_module(root, p) for p in files}
    lines = long = fairly_long = many = complex_ = 0
    per_package = dict.fromkeys(PACKAGES, 0)
    private, longest, radon_missing = [], [], False
    for path in files:
        source = path.read_text(encoding="utf-8")
        tree = ast.parse(source, filename=str(path))
        module = _module(root, path)
        here = sum(1 for line in source.splitlines() if line.strip())
        lines += here
        per_package[module.split(".")[0]] += here
        for fn in _functions(tree):
            length = fn.end_lineno - fn.lineno + 1
            long += length > LONG_LINES
            fairly_long += length > FAIRLY_LONG_LINES
            many += parameter_count(fn) >= MANY_PARAMETERS
            longest.append((length, f"{module}.{fn.name}"))
        private += [f"{module} imports {name}" for _, name in private_imports(root, path, modules)]
        cc = complexities(source)
        if cc is None:
            radon_missing = True
        else:
            complex_ += sum(c > COMPLEX for _, c in cc)
    tests = [p for p in _files(root, ("tests",)) if p.name != "tolerances.py"]
    tolerances = sum(literal_tolerances(ast.parse(p.read_text(encoding="utf-8"))) for p in tests)
    return {
        "lines of Python in the packages": lines,
        **{f"lines in {package}/": n for package, n in per_package.items()},
        f"functions over {FAIRLY_LONG_LINES} lines": fairly_long,
        f"functions over {LONG_LINES} lines": long,
        f"functions with {MANY_PARAMETERS}+ parameters": many,
        f"complexity over {COMPLEX} (radon)": "radon not installed" if radon_missing else complex_,
        "pairs of repeated blocks (6+ lines)": repeated_pairs(root),
        "private imports across modules": len(private),
        "literal tolerances in tests": tolerances,
        "longest": sorted(longest, reverse=True)[:10],
        "private": private,
    }


def tree_at(commit: str, into: Path) -> Path:
    """The packages and tests of ``commit``, extracted with ``git archive`` (nothing checked out)."""
    data = subprocess.run(
        ["git", "archive", "--format=tar", commit, *PACKAGES, "tests"], capture_output=True, check=True
    ).stdout
    with tarfile.open(fileobj=BytesIO(data)) as tar:
        tar.extractall(into, filter="data")
    return into


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", help="a commit to measure beside the working tree")
    ap.add_argument("--out", help="write the report here too")
    args = ap.parse_args(argv)
    try:
        import radon

        versions = f"radon {radon.__version__}"
    except ImportError:
        versions = "radon not installed"
    report = Report("The house, measured", "benchmarks/code_measures.py", argv, versions)
    root = Path(__file__).resolve().parents[1]
    after = measure(root)
    columns = {"now": after}
    if args.before:
        with tempfile.TemporaryDirectory() as tmp:
            columns = {args.before: measure(tree_at(args.before, Path(tmp))), "now": after}
    report.say("| measure | " + " | ".join(columns) + " |")
    report.say("|---|" + "---|" * len(columns))
    for key, value in after.items():
        if key not in ("longest", "private"):
            report.say(f"| {key} | " + " | ".join(str(c[key]) for c in columns.values()) + " |")
    report.say()
    report.say("Longest functions now: " + "; ".join(f"{name} {n}" for n, name in after["longest"]))
    if after["private"]:
        report.say("Private imports now: " + "; ".join(after["private"]))
    return report.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
