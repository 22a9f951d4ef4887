"""A griffe extension for the API pages: the docstrings' Sphinx roles become links, entry points come first.

The docstrings cross-reference with Sphinx roles (``:func:`calibrate```, ``:class:`~classic.result.Result```,
``:data:``, ``:meth:``, ``:attr:``, ``:mod:``), which mkdocstrings would print as raw text. When a package is
loaded this rewrites each role, in every docstring of the package, into an optional autorefs link
(``<autoref identifier="PATH" optional><code>NAME</code></autoref>``) to the object's documented path:

- a dotted name in one of the project's packages (:data:`PROJECT`) is taken as the path;
- a short name (``calibrate``, ``Result.sigma``) is looked up in the scopes around the docstring's object (the
  object, its class, its module), an imported name followed to where it is defined;
- a name outside the project (``numpy.ndarray``, ``torch.nn.Module``), or one not found, becomes plain code.

The links are optional: an object that no page renders (a private helper) reads as plain code instead of
failing ``mkdocs build --strict``. ``~`` shows the last component only, as in Sphinx; ``:math:`x``` becomes
code. Each module's ``__all__`` is reordered so that its functions and classes come before its constants
(the same names, so what is public does not change), and ``mkdocs.yml`` orders members by ``__all__``: a
module's entry points head its section (``calibrate`` first on the classic page).

Enabled in ``mkdocs.yml`` (``extensions: [docs/hooks/sphinx_roles.py]``); ``tests/test_docs_site.py``
builds the site and fails where a raw role reaches its HTML.
"""

from __future__ import annotations

import html
import re
from typing import Any

from griffe import Alias, AliasResolutionError, CyclicAliasError, Extension, GriffeLoader, Module, Object

#: The project's top-level packages: a dotted name under one of them is the project's.
PROJECT = ("classic", "handeye", "learned", "sim", "benchmarks")
#: A cross-reference role and its target, ``~`` and a trailing ``()`` included (a target wrapped across lines
#: is read without its line break).
ROLE = re.compile(r":(?:py:)?(func|class|data|meth|attr|mod|exc|obj|const):`(~?)([\w.]+(?:\s*\n\s*[\w.]+)*)(\(\))?`")
#: Sphinx's inline math: printed as code.
MATH = re.compile(r":math:`([^`]+)`")


def _in_project(path: str) -> bool:
    return path.split(".", 1)[0] in PROJECT


def _target(member: Object | Alias) -> str:
    """The path of the object a member names: an imported name's target, without resolving it."""
    return member.target_path if isinstance(member, Alias) else member.path


def _lookup(name: str, scope: Object) -> str | None:
    """The full path of ``name`` (``a`` or ``a.b``) seen from ``scope`` and the scopes around it."""
    first, _, rest = name.partition(".")
    while scope is not None:
        member = scope.members.get(first) if hasattr(scope, "members") else None
        if member is not None:
            path = _target(member)
            return f"{path}.{rest}" if rest else path
        if scope.name == first:  # the role names its own object or class
            return f"{scope.path}.{rest}" if rest else scope.path
        scope = scope.parent
    return None


def resolve(name: str, obj: Object) -> str | None:
    """The documented path ``name`` refers to from ``obj``'s docstring, or None outside the project."""
    path = name if _in_project(name) else _lookup(name, obj)
    return path if path is not None and _in_project(path) else None


def rewrite(text: str, obj: Object) -> str:
    """``text`` with its roles as optional autorefs links (or code) and its ``:math:`` as code."""

    def link(m: re.Match) -> str:
        _, tilde, name, call = m.groups()
        name = re.sub(r"\s+", "", name)
        shown = (name.rsplit(".", 1)[-1] if tilde else name) + (call or "")
        path = resolve(name, obj)
        if path is None:
            return f"`{shown}`"
        return f'<autoref identifier="{html.escape(path)}" optional><code>{html.escape(shown)}</code></autoref>'

    return MATH.sub(lambda m: f"`{m[1]}`", ROLE.sub(link, text))


def _callables_first(module: Module) -> None:
    """``__all__`` with the module's functions and classes before its other names (same names, same set)."""
    if not module.exports:
        return
    names = list(module.exports)

    def rank(name: str) -> int:
        member = module.members.get(str(name))
        try:
            return 0 if member is not None and (member.is_function or member.is_class) else 1
        except (AliasResolutionError, CyclicAliasError):  # an imported name griffe cannot follow: with the data
            return 1

    module.exports = sorted(names, key=rank)


def _walk(obj: Object):
    yield obj
    for member in obj.members.values():
        if not isinstance(member, Alias):
            yield from _walk(member)


class SphinxRoles(Extension):
    """Rewrite the roles of every docstring of a loaded package; order each module's ``__all__``."""

    def on_package(self, *, pkg: Module, loader: GriffeLoader, **kwargs: Any) -> None:
        for obj in _walk(pkg):
            if obj.docstring is not None:
                obj.docstring.value = rewrite(obj.docstring.value, obj)
            if obj.is_module:
                _callables_first(obj)
