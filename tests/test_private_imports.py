"""No module reaches into another module's private names (issue 42, item 5).

What counts, in every ``.py`` file of ``handeye/``, ``classic/``, ``sim/``, ``learned/`` and ``benchmarks/``
(lazy imports inside functions too):

- ``from M import _name`` where ``M`` is another project module (relative imports resolved);
- ``M._name`` where ``M`` is bound in the file to another project module (``import M``, ``import M as m``,
  ``from pkg import M``; dotted chains such as ``classic.shah._shah`` too);
- ``from P._mod import name`` / ``import P._mod`` from outside the package ``P``: a module whose name begins
  with ``_`` (``classic._linear``, ``benchmarks._report``) is private to its package.

``_name`` is a name with one leading underscore: dunders (``__version__``) are public. Allowed:

- a module's use of its own names (nothing to import);
- a package's ``__init__`` importing private names of the modules inside it (a re-export);
- a private module imported inside its own package (``classic._linear`` from ``classic.tsai``).

Not counted: names of modules outside the project (``os._exit``), and private attributes of objects and classes
(``fit._cache``, ``Motions._x``): only modules' names are.
"""

from __future__ import annotations

import ast
from pathlib import Path

from tests.test_layers import REPO, module_name

PACKAGES = ("handeye", "classic", "sim", "learned", "benchmarks")


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _package_files() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (REPO / pkg).rglob("*.py"))


def _modules() -> set[str]:
    return {module_name(p) for p in _package_files()}


def _outside_private_module(target: str, own: str) -> bool:
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


def private_imports(path: Path, modules: set[str]) -> list[tuple[int, str]]:
    """``(line, dotted name)`` of every private name of another project module that ``path`` uses.

    Parameters
    ----------
    path : Path
        A project file.
    modules : set of str
        The project's dotted module names (:func:`_modules`).

    Returns
    -------
    list of (int, str)
    """
    own = module_name(path)
    package = own.split(".") if path.name == "__init__.py" else own.split(".")[:-1]
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found, aliases = [], {}  # local name -> the project module it is bound to

    def check(line: int, target: str, name: str | None) -> None:
        if target == own:
            return
        full = f"{target}.{name}" if name else target
        if full in modules:  # a module: private to its package only
            bad = _outside_private_module(full, own)
        else:
            reexport = path.name == "__init__.py" and target.startswith(own + ".")
            bad = _outside_private_module(target, own) or (name is not None and _private(name) and not reexport)
        if bad:
            found.append((line, full))

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in PACKAGES:
                    check(node.lineno, a.name, None)
                    # `import a.b` binds `a` (the chain resolves below), `import a.b as m` binds `m`
                    aliases[a.asname or a.name.split(".")[0]] = a.name if a.asname else a.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            mod = ".".join(base + ([node.module] if node.module else []))
            if mod.split(".")[0] not in PACKAGES:
                continue
            for a in node.names:
                check(node.lineno, mod, a.name)
                if f"{mod}.{a.name}" in modules:
                    aliases[a.asname or a.name] = f"{mod}.{a.name}"
    for node in ast.walk(tree):  # a second pass: a lazy import may come after a use in the walk's order
        if not (isinstance(node, ast.Attribute) and _private(node.attr)):
            continue
        chain = _dotted(node.value)
        head, _, rest = (chain or "").partition(".")
        if head not in aliases:
            continue
        target = aliases[head] + (f".{rest}" if rest else "")
        if target in modules and target != own:
            found.append((node.lineno, f"{target}.{node.attr}"))
    return found


def violations() -> list[tuple[str, int, str]]:
    """Every private cross-module use in the project: ``(file, line, name)``."""
    modules = _modules()
    out = []
    for path in _package_files():
        rel = str(path.relative_to(REPO))
        out += [(rel, line, name) for line, name in private_imports(path, modules)]
    return out


def test_no_module_uses_another_modules_private_names():
    bad = [f"{file}:{line} uses {name}" for file, line, name in violations()]
    assert bad == [], "\n".join(bad)


def test_the_check_catches_every_form():
    """Probe files inside the tree: each forbidden form is flagged with its line, the allowed ones are not."""
    probe = REPO / "handeye" / "_private_probe_tmp.py"
    init_dir = REPO / "classic" / "_private_probe_pkg"
    probe.write_text(
        "import classic.shah\n"
        "import handeye.ros_bag as rb\n"
        "from classic import park\n"
        "from classic.motions import Motions\n"
        "from classic._linear import check_motions\n"
        "\n"
        "def f():\n"
        "    from classic.li import _li_secret\n"
        "    return classic.shah._shah_secret, rb._open_secret, park._park_secret, Motions._cached, _own()\n"
        "\n"
        "def _own():\n"
        "    return f.__name__\n"
    )
    init_dir.mkdir()
    (init_dir / "__init__.py").write_text("from ._inner import _helper\nfrom classic.shah import _not_inside\n")
    (init_dir / "_inner.py").write_text("from classic._linear import check_motions\n\ndef _helper():\n    pass\n")
    try:
        modules = _modules()
        found = private_imports(probe, modules)
        in_init = private_imports(init_dir / "__init__.py", modules)
        inner = private_imports(init_dir / "_inner.py", modules)
    finally:
        probe.unlink()
        for p in sorted(init_dir.iterdir()):
            p.unlink()
        init_dir.rmdir()
    assert sorted(found) == [
        (5, "classic._linear.check_motions"),
        (8, "classic.li._li_secret"),
        (9, "classic.park._park_secret"),
        (9, "classic.shah._shah_secret"),
        (9, "handeye.ros_bag._open_secret"),
    ]
    assert in_init == [(2, "classic.shah._not_inside")]  # its own package's modules re-exported: allowed
    assert inner == []  # a private module of the same package: allowed


if __name__ == "__main__":
    for file, line, name in violations():
        print(f"{file}:{line} {name}")
