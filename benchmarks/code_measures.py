"""The rooms of the house, measured: long functions, long parameter lists, branching, private imports, tolerances.

Run from the repository root::

    python benchmarks/code_measures.py                          # the working tree
    python benchmarks/code_measures.py --before 0cd7060          # a commit beside it, as "before -> after"
    python benchmarks/code_measures.py --before 0cd7060 --out benchmarks/results/code_measures.md

Measured over the packages (``handeye/``, ``classic/``, ``sim/``, ``learned/``); the tolerances over ``tests/``.
A commit is read with ``git archive`` into a temporary folder, never checked out. What each row counts:

- *lines*: non-blank lines of Python;
- *functions over 100 lines*: from ``def`` to the function's last line, docstring included (nested functions
  count on their own);
- *functions with 8+ parameters*: positional, keyword-only and ``*args`` / ``**kwargs`` each count one;
  ``self`` and ``cls`` do not;
- *complexity over 10*: radon's cyclomatic complexity (McCabe) of each function and method, as
  ``radon cc`` reports it;
- *private imports across modules*: ``from a.b import _name`` where ``a.b`` is another project module
  (a package's ``__init__`` lending its own modules' names aside);
- *literal tolerances in tests*: ``atol=``, ``rtol=``, ``abs=``, ``rel=`` given a number written in the test
  (not a name from ``tests/tolerances.py``), outside ``tests/tolerances.py``.

Repeated blocks are the workplace's ``duplicates`` tool's to count, and the test suite's wall time is CI's:
both are quoted in the CHANGELOG beside these.
"""

from __future__ import annotations

import argparse
import ast
import os
import subprocess
import sys
import tarfile
import tempfile
from io import BytesIO
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._report import Report  # noqa: E402

PACKAGES = ("handeye", "classic", "sim", "learned")
TOLERANCE_KEYWORDS = ("atol", "rtol", "abs", "rel")
LONG_LINES = 100
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


def private_imports(module: str, tree: ast.AST, modules: set) -> list[str]:
    """``from other import _name`` of another project module (absolute imports; a package lending its own aside)."""
    out = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom) or node.level or not node.module or node.module == module:
            continue
        if node.module not in modules or module.startswith(node.module + "."):
            continue
        out += [f"{module} imports {node.module}.{a.name}" for a in node.names if a.name.startswith("_")]
    return out


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


def measure(root: Path) -> dict:
    """The measures of a tree (see the module's docstring); ``longest`` lists the ten longest functions."""
    files = _files(root, PACKAGES)
    modules = {_module(root, p) for p in files}
    lines = long = many = complex_ = 0
    private, longest, radon_missing = [], [], False
    for path in files:
        source = path.read_text(encoding="utf-8")
        tree = ast.parse(source, filename=str(path))
        module = _module(root, path)
        lines += sum(1 for line in source.splitlines() if line.strip())
        for fn in _functions(tree):
            length = fn.end_lineno - fn.lineno + 1
            long += length > LONG_LINES
            many += parameter_count(fn) >= MANY_PARAMETERS
            longest.append((length, f"{module}.{fn.name}"))
        private += private_imports(module, tree, modules)
        cc = complexities(source)
        if cc is None:
            radon_missing = True
        else:
            complex_ += sum(c > COMPLEX for _, c in cc)
    tests = [p for p in _files(root, ("tests",)) if p.name != "tolerances.py"]
    tolerances = sum(literal_tolerances(ast.parse(p.read_text(encoding="utf-8"))) for p in tests)
    return {
        "lines of Python in the packages": lines,
        f"functions over {LONG_LINES} lines": long,
        f"functions with {MANY_PARAMETERS}+ parameters": many,
        f"complexity over {COMPLEX} (radon)": "radon not installed" if radon_missing else complex_,
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
