"""numba's on-disk cache made to notice a change in any kernel of the package, not only in its own file.

numba keys a cached kernel on its own source file alone (a hash of its content from numba 0.6x, its time and
size before): a kernel that calls one defined in another file, which it compiles in, keeps the old callee's
code until its own file changes (numba's documentation: "Cache invalidation fails to recognize changes in
functions defined in a different file"; numba issue 1833). It also keeps the module constants it read when
it was compiled. An upgrade that changes ``sw_refine.py`` alone would build with the old patch-order search
inside ``sw_layout._finish``: outputs that the release's build versions do not describe, written by a tool
that says it is up to date. A developer's edit goes stale the same way (a bit-for-bit check passed on old
code).

:func:`install` puts a locator in front of numba's own for the package's kernels: numba's locator for the
function (the same cache folder), its source stamp paired with :func:`kernel_fingerprint`, a hash of every
module of the package that imports numba and of the package modules those import directly (the constants a
kernel may read). A change in any of them recompiles the package's kernels once; a change elsewhere (the
pipeline, the command line) does not. Importing this module installs it for this package: the encoders'
and the simplifier's ``__init__``, ``format.kernels``, ``metrics`` and ``vcache`` import it before their
kernels are defined (tests check every cached kernel of the package has the locator, whatever module a
process imports first: a kernel stamped both ways would have its cache index rewritten by turns).
"""

from __future__ import annotations

import functools
import hashlib
import re
import zipfile
from pathlib import Path
from typing import Any

PACKAGE = "swpm_usd"
_ROOT = Path(__file__).resolve().parent


def _py_files(root: Path) -> list[tuple[tuple[str, ...], Any]]:
    """(parts of the path under ``root``, file) for every ``.py`` file under ``root``: a folder, or a folder
    inside a zip archive the package is imported from (numba caches such kernels too, stamped with their
    own file alone). A file is a :class:`~pathlib.Path` or a :class:`zipfile.Path`: both read_bytes()."""
    if root.is_dir():
        return [(path.relative_to(root).parts, path) for path in root.rglob("*.py")]
    archive = next((a for a in root.parents if a.is_file() and zipfile.is_zipfile(a)), None)
    if archive is None:
        return []
    out: list[tuple[tuple[str, ...], Any]] = []
    folders = [((), zipfile.Path(archive, at=root.relative_to(archive).as_posix() + "/"))]
    while folders:
        parts, folder = folders.pop()
        for entry in folder.iterdir():
            if entry.is_dir():
                folders.append(((*parts, entry.name), entry))
            elif entry.name.endswith(".py"):
                out.append(((*parts, entry.name), entry))
    return out


def _modules(root: Path, package: str) -> dict[str, Any]:
    """Module name -> file, for every ``.py`` file under ``root`` (the folder of ``package``) that can be
    imported as a module: not an editor's lock file (emacs's ``.#name.py``, a link to nowhere, read would
    fail every kernel's definition) or backup."""
    out = {}
    for rel, path in sorted(_py_files(root), key=lambda item: item[0]):
        parts = [*rel[:-1], rel[-1].removesuffix(".py")]
        if not all(part.isidentifier() for part in parts):
            continue
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join([package, *parts])] = path
    return out


#: a module that imports numba (``import numba_cache`` is not one)
_USES_NUMBA = re.compile(rb"^[ \t]*(?:import|from)[ \t]+numba\b", re.MULTILINE)
#: ``from X import names`` (names in parentheses over several lines, or to the line's end) and ``import X``;
#: a regular expression, not ``ast``: a tenth of the time (the fingerprint is taken in every process that
#: compiles or loads a kernel), and a name it takes for a module when it is not only adds a file to the hash
_FROM_IMPORT = re.compile(r"^[ \t]*from[ \t]+(\.*)([\w.]*)[ \t]+import[ \t]+(\([^)]*\)|[^\n]*)", re.MULTILINE)
_IMPORT = re.compile(r"^[ \t]*import[ \t]+([\w., \t]+)", re.MULTILINE)


def _imports_of(name: str, is_package: bool, text: str, modules: dict[str, Any]) -> set[str]:
    """The modules of ``modules`` that module ``name`` (a package's ``__init__`` if ``is_package``; its source
    ``text``) imports by name."""
    here = name.split(".") if is_package else name.split(".")[:-1]
    found: set[str] = set()
    for dots, module, names in _FROM_IMPORT.findall(text):
        base = here[: len(here) - len(dots) + 1] if dots else []
        target = ".".join(base + ([module] if module else []))
        words = re.sub(r"#[^\n]*", "", names).strip("()").split(",")
        found |= {target} | {f"{target}.{w.split()[0]}" for w in words if w.split()}
    for names in _IMPORT.findall(text):
        found |= {w.split()[0] for w in names.split(",") if w.split()}
    return found & modules.keys()


@functools.cache
def kernel_fingerprint(root: Path = _ROOT, package: str = PACKAGE) -> str:
    """A hash of the sources a kernel of ``package`` (under ``root``) may be compiled from: every module
    that imports numba, and the package modules each of them imports."""
    modules = _modules(root, package)
    source = {m: path.read_bytes() for m, path in modules.items()}  # (each file read once)
    kernels = {m for m, text in source.items() if _USES_NUMBA.search(text)}
    covered = set(kernels)
    for m in kernels:
        is_package = modules[m].name == "__init__.py"
        covered |= _imports_of(m, is_package, source[m].decode("utf-8"), modules)
    digest = hashlib.sha256()
    for m in sorted(covered):
        digest.update(m.encode() + b"\0" + source[m] + b"\0")
    return digest.hexdigest()


#: package -> its folder (maybe inside a zip archive), for the packages :func:`install` has been called for
_PACKAGES: dict[str, Path] = {}


@functools.cache
def _locator_class() -> type | None:
    """The locator class, made once; None if this numba has no locator list to put it in."""
    from numba.core import caching

    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    base = getattr(caching, "_CacheLocator", None)
    if impl is None or base is None or not isinstance(getattr(impl, "_locator_classes", None), list):
        return None

    class PackageKernelLocator(base):  # type: ignore[misc, valid-type]
        """numba's own locator for a kernel of an installed package, its stamp paired with the package's
        kernel fingerprint."""

        def __init__(self, inner: Any, fingerprint: str) -> None:
            self._inner = inner
            self.fingerprint = fingerprint

        def ensure_cache_path(self) -> None:
            self._inner.ensure_cache_path()

        def get_cache_path(self) -> str:
            return self._inner.get_cache_path()

        def get_source_stamp(self) -> Any:
            return (self._inner.get_source_stamp(), self.fingerprint)

        def get_disambiguator(self) -> str:
            return self._inner.get_disambiguator()

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            module = getattr(py_func, "__module__", None) or ""
            package = next((p for p in _PACKAGES if module == p or module.startswith(p + ".")), None)
            if package is None:
                return None
            for other in impl._locator_classes:
                inner = None if other is cls else other.from_function(py_func, py_file)
                if inner is not None:
                    return cls(inner, kernel_fingerprint(_PACKAGES[package], package))
            return None

    impl._locator_classes.insert(0, PackageKernelLocator)
    return PackageKernelLocator


def install(package: str = PACKAGE, root: Path | str = _ROOT) -> bool:
    """Stamp the cached kernels of ``package`` (its folder ``root``) with :func:`kernel_fingerprint`, for
    the kernels defined from now on. Idempotent; False if this numba has no locator list (then nothing
    changes: numba's own stamps)."""
    if _locator_class() is None:
        return False
    _PACKAGES[package] = Path(root).resolve()
    return True


install()
