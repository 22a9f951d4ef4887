"""Optional dependencies: import them or say which extra installs them."""

from __future__ import annotations

import importlib
from types import ModuleType

from handeye.core.errors import MissingDependencyError


def require_package(module: str, extra: str, purpose: str | None = None) -> ModuleType:
    """Import an optional module, or raise an error naming the extra to install.

    Parameters
    ----------
    module : str
        Importable module name, e.g. ``"torch"`` or ``"cv2"``.
    extra : str
        The ``handeye`` extra that provides it, e.g. ``"learned"``.
    purpose : str, optional
        What the module is needed for, added to the message.

    Returns
    -------
    module : ModuleType
        The imported module.

    Raises
    ------
    MissingDependencyError
        If the import fails; the message says ``pip install "handeye[extra]"``.

    Examples
    --------
    >>> np = require_package("numpy", extra="core")
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        why = f" (needed for {purpose})" if purpose else ""
        raise MissingDependencyError(
            f"the optional package '{module}' is not installed{why}; install it with: pip install \"handeye[{extra}]\""
        ) from exc
