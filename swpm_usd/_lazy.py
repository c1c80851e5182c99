"""Names a package re-exports from modules it imports on first use (PEP 562's module ``__getattr__``).

The reader, the writer and the encoders load numba and every kernel's cache (about 0.4 s); the command
line's ``--help``, a config check and a pipeline run with nothing to build need none of them, so the
packages that re-export them (:mod:`swpm_usd`, :mod:`swpm_usd.format`) import them when a name is first used.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import import_module
from typing import Any


def lazy_attributes(package: str, names: dict[str, str]) -> tuple[Callable[[str], Any], Callable[[], list]]:
    """``(__getattr__, __dir__)`` for ``package``: ``names`` maps an attribute to the submodule (relative,
    without the dot) that defines it, or a submodule's name to itself (the submodule: ``swpm_usd.format``
    after ``import swpm_usd``, as when the package imported it). A name found is kept in the package's
    namespace, so later look-ups do not come here."""
    import sys

    def getattr_(name: str) -> Any:
        if name not in names:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module = import_module(f"{package}.{names[name]}")
        value = module if names[name] == name else getattr(module, name)
        setattr(sys.modules[package], name, value)
        return value

    def dir_() -> list:
        return sorted(set(vars(sys.modules[package])) | set(names))

    return getattr_, dir_
