"""numba's cache stamped with the package's kernel fingerprint (swpm_usd.numba_cache): a kernel whose callee
in another file changed is compiled again, not loaded with the old callee inside."""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numba
from numba.core.caching import NullCache

import swpm_usd
from swpm_usd import numba_cache


def _kernel_modules() -> list[str]:
    modules = numba_cache._modules(numba_cache._ROOT, numba_cache.PACKAGE)
    return sorted(m for m, p in modules.items() if numba_cache._USES_NUMBA.search(p.read_bytes()))


def test_every_cached_kernel_of_the_package_is_stamped_with_the_fingerprint():
    seen = 0
    for name in _kernel_modules():
        module = importlib.import_module(name)
        for attr, value in vars(module).items():
            if not isinstance(value, numba.core.dispatcher.Dispatcher):
                continue
            if value.py_func.__module__ != name or isinstance(value._cache, NullCache):
                continue
            locator = value._cache._impl.locator
            assert type(locator).__name__ == "PackageKernelLocator", f"{name}.{attr}: {type(locator)}"
            assert locator.get_source_stamp()[1] == numba_cache.kernel_fingerprint(), f"{name}.{attr}"
            seen += 1
    assert seen > 100  # (the package has about 180 cached kernels)


def _write(root: Path, files: dict[str, str]) -> None:
    for rel, text in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(textwrap.dedent(text))


def test_fingerprint_covers_the_kernels_and_what_they_import_only(tmp_path: Path):
    root = tmp_path / "pkgf"
    _write(
        root,
        {
            "__init__.py": "",
            "consts.py": "SCALE = 10\n",
            "kern.py": "import numba\nfrom .consts import SCALE\nfrom . import (\n    helpers,  # x\n)\n",
            "helpers.py": "def h():\n    return 1\n",
            "cli.py": "from .kern import SCALE\n",
        },
    )
    fp = lambda: numba_cache.kernel_fingerprint.__wrapped__(root, "pkgf")  # noqa: E731 (uncached)
    first = fp()
    (root / "cli.py").write_text("from .kern import SCALE  # a command-line change\n")
    assert fp() == first  # imports a kernel module, is not imported by one
    for rel, text in (("consts.py", "SCALE = 11\n"), ("helpers.py", "def h():\n    return 2\n")):
        before = fp()
        (root / rel).write_text(text)
        assert fp() != before, rel  # a constant, a module a kernel module imports in parentheses


def test_fingerprint_skips_files_that_are_not_modules(tmp_path: Path):
    # emacs's lock file for a modified buffer is a link to nowhere named .#kern.py: reading it raised
    # FileNotFoundError as the package's first kernel was defined (numba alone imported)
    root = tmp_path / "pkgl"
    _write(root, {"__init__.py": "", "kern.py": "import numba\n"})
    first = numba_cache.kernel_fingerprint.__wrapped__(root, "pkgl")
    (root / ".#kern.py").symlink_to(root / "user@host.1234")
    _write(root, {"kern-backup.py": "import numba\nX = 1\n"})
    assert numba_cache.kernel_fingerprint.__wrapped__(root, "pkgl") == first


_CALLEE = """
import numba as nb

@nb.njit(cache=True)
def step(x):
    return x + {n}
"""
_CALLER = """
import numba as nb
from .callee import step

@nb.njit(cache=True)
def scaled(x):
    return step(x) * 10
"""


def _printed(code: str, env: dict[str, str]) -> str:
    """What a fresh Python process running ``code`` under ``env`` prints (it must succeed)."""
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_a_kernel_is_compiled_again_when_its_callee_in_another_file_changes(tmp_path: Path):
    pkg = tmp_path / "pkgx"
    init = "from swpm_usd import numba_cache\nnumba_cache.install(__name__, __path__[0])\n"
    _write(pkg, {"__init__.py": init, "callee.py": _CALLEE.format(n=1), "caller.py": _CALLER})
    env = dict(os.environ)
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "cache")
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), str(Path(swpm_usd.__file__).parents[1])])

    def run() -> str:
        return _printed("from pkgx.caller import scaled; print(scaled(1))", env)

    assert run() == "20"
    assert run() == "20"  # (from the cache)
    (pkg / "callee.py").write_text(textwrap.dedent(_CALLEE.format(n=2)))
    # numba alone loads caller.py's cached kernel, its own file unchanged, with the old step inside: 20
    assert run() == "30"


_STAMPED_WHEN_FIRST = """
import importlib, sys
import numba
from numba.core.caching import NullCache
name = sys.argv[1]
module = importlib.import_module(name)  # the first module of the package this process imports
for attr, value in vars(module).items():
    if isinstance(value, numba.core.dispatcher.Dispatcher) and value.py_func.__module__ == name:
        if not isinstance(value._cache, NullCache):
            print(attr, type(value._cache._impl.locator).__name__)
"""


def test_every_cached_kernel_is_stamped_whatever_module_a_process_imports_first():
    # (metrics and vcache are outside encode/ and simplify/, whose __init__ install the locator: imported
    # first, their kernels had numba's stamp alone, and a process importing them later had the package's:
    # the two rewrote each other's cache index)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(Path(swpm_usd.__file__).parents[1]), env.get("PYTHONPATH", "")])
    unstamped, seen = [], 0
    for name in _kernel_modules():  # (one process each: a few seconds in all)
        argv = [sys.executable, "-c", _STAMPED_WHEN_FIRST, name]
        out = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, f"{name}: {out.stderr}"
        for line in out.stdout.splitlines():
            attr, locator = line.split()
            seen += 1
            if locator != "PackageKernelLocator":
                unstamped.append(f"{name}.{attr}: {locator}")
    assert seen > 100
    assert unstamped == []


def _zip(folder: Path, archive: Path) -> None:
    with zipfile.ZipFile(archive, "w") as zf:  # (no folder entries, as many tools write)
        for path in sorted(folder.rglob("*.py")):
            zf.write(path, path.relative_to(folder.parent).as_posix())


def test_a_package_imported_from_a_zip_archive_has_the_same_fingerprint(tmp_path: Path):
    # numba caches a zipped module's kernels (ZipCacheLocator) stamped with their own file's bytes; the
    # fingerprint found no file under a folder inside the archive: every kernel stamped with the empty hash
    root = tmp_path / "src" / "pkgz"
    _write(root, {"__init__.py": "", "kern.py": "import numba\nfrom .sub import c\n", "sub/c.py": "N = 1\n"})
    _zip(root, tmp_path / "a.zip")
    fp = numba_cache.kernel_fingerprint.__wrapped__
    assert fp(tmp_path / "a.zip" / "pkgz", "pkgz") == fp(root, "pkgz")
    _write(root, {"sub/c.py": "N = 2\n"})
    _zip(root, tmp_path / "b.zip")
    assert fp(tmp_path / "b.zip" / "pkgz", "pkgz") != fp(tmp_path / "a.zip" / "pkgz", "pkgz")


def test_a_kernel_from_a_zip_archive_is_compiled_again_when_its_callee_changes(tmp_path: Path):
    pkg = tmp_path / "src" / "pkgw"
    init = "from swpm_usd import numba_cache\nnumba_cache.install(__name__, __path__[0])\n"
    _write(pkg, {"__init__.py": init, "callee.py": _CALLEE.format(n=1), "caller.py": _CALLER})
    archive = tmp_path / "pkgw.zip"
    env = dict(os.environ)
    env["XDG_CACHE_HOME"] = str(tmp_path / "cache")  # (numba's zip locator caches in the user's folder)
    env["PYTHONPATH"] = os.pathsep.join([str(archive), str(Path(swpm_usd.__file__).parents[1])])

    def run() -> str:
        code = "from pkgw.caller import scaled; print(scaled(1), scaled.stats.cache_hits.total())"
        return _printed(code, env)

    _zip(pkg, archive)
    assert run() == "20 0"
    assert run() == "20 1"  # (from the cache)
    _write(pkg, {"callee.py": _CALLEE.format(n=2)})
    _zip(pkg, archive)
    assert run() == "30 0"
