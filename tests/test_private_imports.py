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

from pathlib import Path

from benchmarks.code_measures import PROJECT, private_imports
from tests.test_layers import REPO, module_name


def _package_files() -> list[Path]:
    return sorted(p for pkg in PROJECT for p in (REPO / pkg).rglob("*.py"))


def _modules() -> set[str]:
    return {module_name(p) for p in _package_files()}


def violations() -> list[tuple[str, int, str]]:
    """Every private cross-module use in the project: ``(file, line, name)``."""
    modules = _modules()
    out = []
    for path in _package_files():
        rel = str(path.relative_to(REPO))
        out += [(rel, line, name) for line, name in private_imports(REPO, path, modules)]
    return out


def test_no_module_uses_another_modules_private_names():
    bad = [f"{file}:{line} uses {name}" for file, line, name in violations()]
    assert bad == [], "\n".join(bad)


def test_the_check_catches_every_form(tmp_path):
    """Probe files in a tree beside the repository's (its modules known): each forbidden form is flagged with its
    line, the allowed ones are not."""
    probe = tmp_path / "handeye" / "_private_probe_tmp.py"
    init_dir = tmp_path / "classic" / "_private_probe_pkg"
    init_dir.mkdir(parents=True)
    probe.parent.mkdir()
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
    (init_dir / "__init__.py").write_text("from ._inner import _helper\nfrom classic.shah import _not_inside\n")
    (init_dir / "_inner.py").write_text("from classic._linear import check_motions\n\ndef _helper():\n    pass\n")
    pkg = "classic._private_probe_pkg"
    modules = _modules() | {"handeye._private_probe_tmp", pkg, f"{pkg}._inner"}
    found = private_imports(tmp_path, probe, modules)
    in_init = private_imports(tmp_path, init_dir / "__init__.py", modules)
    inner = private_imports(tmp_path, init_dir / "_inner.py", modules)
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
