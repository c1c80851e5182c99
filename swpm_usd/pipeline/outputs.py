"""The run's files in output.dir: what it writes, which are still as recorded, and what it cleans up.

:func:`_checked_output` decides whether an output is still the file its record describes (by size and stat,
else by sha256); :func:`planned_outputs` and :func:`_overwritten_inputs` keep a run from writing over its own
inputs; the rest clean up after a killed run or worker (temporary files, outputs a worker had kept aside),
name or delete the outputs of assets no longer in the config (and those a rebuild no longer writes), and keep
an asset's previous build when its rebuild fails (:func:`_keep_previous`). Separate from the runner: file
checks and clean-up rules, each a function the run calls at one step.
"""

from __future__ import annotations

import contextlib
import fnmatch
import glob
import os
import stat
from pathlib import Path
from typing import Any

from ..codes import PROBLEM_KEYS
from .assets import Asset, _folded
from .config import Config, ConfigError
from .file_hash import STAT_KEYS, hash_with_stat, stat_fields
from .lock import LOCK
from .manifest import _RUN_OUTPUT_DEFAULTS, MANIFEST, ORPHANED, RUN_OUTPUTS, _asks_for
from .records import record_problem
from .rules import OUTPUT_SUFFIXES, _names_moved, _wanted_outputs
from .scene import _layer_with_units
from .worker import USD_TEMPORARY_SUFFIX

#: temporary files a run leaves in output.dir if it is killed (the atomic writes', the USD layers' staged by
#: the workers and the scene's, and usd-core's own beside those two: ``.<stem>.tmp.XXXXXX``), which the next
#: run deletes, as a run stopped by an error or Ctrl-C does once its workers are stopped
_TEMPORARY = (".*.tmp", ".*.tmp.usdc", ".*.tmp.usda", ".*.tmp.??????")


def _remove_temporary(out_dir: Path) -> None:
    for stale in [p for pattern in _TEMPORARY for p in out_dir.glob(pattern)]:
        stale.unlink(missing_ok=True)


def _clean_after_worker(out_dir: Path, records: dict, stem: str) -> None:
    """A worker stopped or dead while it built the asset of outputs ``stem``.*: its previous outputs that the
    worker had kept aside are put back (:func:`_restore_kept_aside`), its temporary files deleted (those of
    the other workers, still building, stay)."""
    names = {f"{stem}.swpm", f"{stem}.usdc"}
    _restore_kept_aside(out_dir, records, names)
    random = "?" * 8  # (tempfile's random part)
    swpm, usd = glob.escape(f"{stem}.swpm"), glob.escape(f"{stem}.usdc")
    for pattern in (
        f".{swpm}.{random}.tmp",
        f".{glob.escape(stem)}.{random}{USD_TEMPORARY_SUFFIX}",
        # (usd-core's as it exports that layer: its name less ``.usdc``, then ``.XXXXXX``, renamed over it)
        f".{glob.escape(stem)}.{random}{USD_TEMPORARY_SUFFIX.removesuffix('.usdc')}.??????",
        f".{swpm}.{random}.prev.tmp",
        f".{usd}.{random}.prev.tmp",
    ):
        for stale in out_dir.glob(pattern):
            stale.unlink(missing_ok=True)


def _restore_kept_aside(out_dir: Path, records: dict, names: set[str] | None = None) -> None:
    """Put back the previous outputs that a worker stopped while it renamed an asset's outputs into place
    (a pool's worker stopped by Ctrl-C, a kill) had kept aside (:func:`.worker._place_outputs`,
    ``.<name>.XXXXXXXX.prev.tmp``), before :func:`_remove_temporary` deletes them: one whose ``<name>`` is
    an output a record of ``records`` (asset id -> manifest record) lists, no longer as recorded (a new file
    the manifest does not list, or none), while the file kept aside is, is renamed back, so the asset is its
    recorded build again, not half of one the manifest does not know."""
    kept = list(out_dir.glob(".*.prev.tmp"))
    if names is not None:  # (those of these outputs alone)
        kept = [p for p in kept if p.name[1 : -len(".prev.tmp")].rpartition(".")[0] in names]
    if not kept:  # (the usual run)
        return
    recorded = {
        o["path"]: o
        for rec in records.values()
        if record_problem(rec) is None
        for o in rec.get("outputs", {}).values()
    }
    for aside in kept:
        name = aside.name[1 : -len(".prev.tmp")].rpartition(".")[0]
        o = recorded.get(name)
        target = out_dir / name
        if o is None or _checked_output(target, o) is not None or _checked_output(aside, o) is None:
            continue
        try:
            os.replace(aside, target)
        except OSError:
            continue
        if target.suffix == ".usdc":
            from ..usd.writer import LayerReloadError, reload_if_open

            # (a reload that fails leaves that open layer as it was: the other files are still put back, and
            # the stopped run still deletes its temporary files and writes its manifest)
            with contextlib.suppress(LayerReloadError):
                reload_if_open(target)


def _unusable_out_dir(cfg: Config, out_dir: Path) -> list[str]:
    """output.dir must be a folder, or creatable: not an existing file, nor under one, nor a link (or under
    one) that leads round in a loop (a traceback, ``RuntimeError: Symlink loop``, once the run resolved its
    manifest's path) or to nothing (``cannot create ...: File exists``)."""
    from ..fileio import link_loop

    where = cfg.where(("output", "dir"))
    loop = link_loop(out_dir)
    if loop is not None:
        under = "" if loop[0] == out_dir else f": its folder {loop[0]}"
        return [f"{where}: {out_dir}{under} is a link loop (to {loop[1]}), not a folder"]
    if out_dir.is_symlink() and not out_dir.exists():
        return [f"{where}: {out_dir} is a link to nothing (to {os.readlink(out_dir)}), not a folder"]
    for p in (out_dir, *out_dir.parents):
        if p.exists():
            if not p.is_dir():
                what = "is a file" if p == out_dir else f"is under {p}, which is a file"
                return [f"{where}: {out_dir} {what}, not a folder"]
            return []
    return []


def _make_out_dir(cfg: Config, out_dir: Path) -> None:
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(
            [f"{cfg.where(('output', 'dir'))}: cannot create {out_dir}: {exc.strerror or exc}"],
            code="OUTPUT_UNWRITABLE",
        ) from None
    if not os.access(out_dir, os.W_OK | os.X_OK):
        # (a read-only mount, root's too, said "permission denied": no chmod helps there)
        try:
            read_only = bool(os.statvfs(out_dir).f_flag & os.ST_RDONLY)
        except (OSError, AttributeError):  # (AttributeError: no statvfs or ST_RDONLY, Windows)
            read_only = False
        why = "it is on a read-only file system" if read_only else "permission denied"
        raise ConfigError(
            [f"{cfg.where(('output', 'dir'))}: cannot write in {out_dir}: {why}"],
            code="OUTPUT_UNWRITABLE",
        )


def _checked_output(path: Path, recorded: dict, verify: bool = False) -> dict | None:
    """``recorded`` (an output's manifest record) when ``path`` is still the file it recorded, else None.

    Its size first. Then, unless ``verify``, its stat: a file with the recorded size, mtime, ctime, inode
    and device (:data:`.file_hash.STAT_KEYS`) is trusted unchanged without being read (a rerun of thousands of
    assets reads none of their outputs). Anything else is hashed: the file is intact when its sha256 is
    the recorded one (a changed byte of a same-size file rebuilds it), and the record returned is then a
    copy with the stat fields of the bytes hashed (recorded anew: a record of an older manifest has
    none, a touched or copied-back file other ones), so the next run trusts it again."""
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode) or st.st_size != recorded.get("size", -1):
            return None
        fields = stat_fields(st)
        if not verify and all(recorded.get(k) == v for k, v in fields.items()):
            return recorded
        sha, hashed = hash_with_stat(path)
    except (OSError, ValueError):  # (ValueError: a path with a NUL byte)
        return None
    if sha != recorded.get("sha256"):
        return None
    fresh = {k: v for k, v in recorded.items() if k not in STAT_KEYS}
    if hashed is not None and hashed.st_size == recorded.get("size"):
        fresh.update(stat_fields(hashed))
    return recorded if fresh == recorded else fresh


def _complete_output_record(path: Path, recorded: dict) -> None:
    """Complete a worker's record of an output it wrote (:func:`.file_hash.output_record`) as this process
    sees the file: its size, and its stat fields when it is still the file the worker hashed (the same
    size, mtime, ctime and inode; the device as this process numbers it, which a Dask worker on another
    machine may not), else none, so the next run hashes it."""
    st = path.stat()
    seen = stat_fields(st)
    same = recorded.get("size") == st.st_size and all(
        recorded.get(k) == seen[k] for k in ("mtime_ns", "ctime_ns", "ino")
    )
    for k in ("size", *STAT_KEYS):
        recorded.pop(k, None)
    recorded["size"] = st.st_size
    if same:
        recorded.update(seen)


def planned_outputs(cfg: Config, out_dir: Path, assets: list[Asset]) -> dict[Path, str]:
    """Every file a run of ``cfg`` writes (or, for temporary files, may delete) -> what it is."""
    out = cfg.data["output"]
    files: dict[Path, str] = {out_dir / MANIFEST: "the run manifest", out_dir / LOCK: "the run's lock file"}
    if out.get("report", True):
        files[out_dir / "report.html"] = "the run report"
    if out.get("scene"):
        files[out_dir / "scene.usda"] = "the scene layer"
    for a in assets:
        if out.get("swpm", True):
            files[out_dir / f"{a.output_stem}.swpm"] = f"the .swpm of {a.id}"
        if out.get("usd", False):
            files[out_dir / f"{a.output_stem}.usdc"] = f"the USD layer of {a.id}"
    return files


def _file_key(path: Path) -> tuple:
    """One key per file: the resolved path, or (device, inode) when it exists (hard links, odd mounts)."""
    try:
        st = path.stat()
        return ("inode", st.st_dev, st.st_ino)
    except OSError:  # (realpath: resolve() raises RuntimeError for a link in a loop)
        return ("path", os.path.realpath(path))


def _overwritten_inputs(
    cfg: Config, out_dir: Path, assets: list[Asset], inputs: dict[str, list[Path]]
) -> list[str]:
    """The run never writes over its own inputs: a file it would write (:func:`planned_outputs`) or a stale
    temporary file it would delete must not be a matched mesh, a stage, a layer a stage uses, or the config
    itself. Located at ``output.dir``.

    A file to write that exists is compared as a file (its device and inode: ``os.path.samefile``); every
    one, written yet or not, is also compared by name with the inputs in output.dir as a case-insensitive
    filesystem compares names (:func:`.assets._folded`: ``out/Scene.usda``, a stage, is the
    ``out/scene.usda`` the run writes on macOS or Windows), as output names that differ only so collide
    (:func:`.assets.discover`): on any filesystem, whether an earlier run wrote the file or not, so the
    refusal is the config's alone. Names of temporary files are compared so too.
    A folder is output.dir when it is that folder (the same device and inode), however its path is spelt."""
    sources: dict[tuple, tuple[Path, str]] = {_file_key(cfg.path): (cfg.path, "the configuration file")}
    seen: set[int] = set()  # (the prims of a stage share one list of its layers: looked up once)
    for a in assets:
        listed = inputs.get(a.id, [])
        if id(listed) in seen:  # (its files, all, named by an earlier asset: setdefault would keep those)
            continue
        seen.add(id(listed))
        for p in listed:
            what = "an input of" if p != a.path else "the input of"
            sources.setdefault(_file_key(p), (p, f"{what} {a.id}"))
    out_key = _file_key(out_dir)
    folders: dict[Path, bool] = {}  # (a folder looked up once: 10,000 inputs in one, a second)
    in_out: list[tuple[Path, str]] = []  # the inputs in output.dir
    for path, what in sources.values():
        if path.parent not in folders:
            folders[path.parent] = out_key[0] == "inode" and _file_key(path.parent) == out_key
        if folders[path.parent]:
            in_out.append((path, what))
    by_name = {_folded(path.name): (path, what) for path, what in in_out}
    problems = []
    for target, what in planned_outputs(cfg, out_dir, assets).items():
        key = _file_key(target)
        # (by name as well when it exists: on a case-sensitive filesystem out/scene.usda, written by an
        # earlier run, is another file than the input out/Scene.usda, and the config alone decides)
        hit = sources.get(key) or by_name.get(_folded(target.name))
        if hit is not None:
            problems.append(
                f"{cfg.where(('output', 'dir'))}: {what} would overwrite {_rel(cfg, hit[0])} "
                f"({hit[1]}); choose an output.dir apart from the inputs (and globs not reaching into it)"
            )
    for path, what in in_out:
        # (folded as a case-insensitive filesystem compares names: .COW.SWPM.ABCDEFGH.TMP is a temporary
        # file of ours there; the patterns are lower case)
        if any(fnmatch.fnmatchcase(_folded(path.name), pattern) for pattern in _TEMPORARY):
            problems.append(
                f"{cfg.where(('output', 'dir'))}: {_rel(cfg, path)} ({what}) is named like a temporary file "
                f"the run deletes from output.dir; rename it or choose another output.dir"
            )
    return problems


def _rel(cfg: Config, path: Path) -> str:
    try:
        return path.resolve().relative_to(cfg.base).as_posix()
    except ValueError:
        return str(path)


#: why an output is left in output.dir, not an output of today's assets (an orphan's ``because`` code; a
#: stable, lower-case contract: ``--json``'s ``orphans`` and the manifest's ``orphaned_outputs`` give it)
ORPHAN_REASONS = (
    "asset-removed",  # its asset left the config (its input deleted or no longer matched)
    "names-changed",  # its asset, still in the config, is rebuilt under another name (output.names flipped)
    "kind-unwanted",  # a kind of output the config no longer asks for (swpm: false), its asset rebuilt
    "run-output-unwanted",  # scene.usda or report.html, the config no longer asking for it
    "earlier-run",  # left by a run of an older version, which recorded no reason
)
#: the keys of an orphan's record beyond its file's (:func:`_orphan_record`): the asset it was an output of
#: (None: a run output, or not recorded) and why it is left (``{"code", "detail"}``, of ORPHAN_REASONS)
ORPHAN_ASSET, ORPHAN_BECAUSE = "asset", "because"


def _orphan_record(checked: dict, asset: str | None, code: str, detail: str = "") -> dict:
    """An orphan's record as the run names it and the manifest keeps it: its file's (path, size, sha256,
    stat), the asset it was an output of and why it is left."""
    assert code in ORPHAN_REASONS, code  # (a programming error: the codes are a contract)
    record = {k: checked[k] for k in ("path", "size", "sha256", *STAT_KEYS) if k in checked}
    return {**record, ORPHAN_ASSET: asset, ORPHAN_BECAUSE: {"code": code, "detail": detail}}


def _recorded_because(o: dict) -> tuple[str | None, str, str]:
    """(asset, code, detail) an ``orphaned_outputs`` entry recorded; an entry of an older version (none, or
    one not of ORPHAN_REASONS: hand-edited) is ``earlier-run``."""
    because = o.get(ORPHAN_BECAUSE)
    asset = o.get(ORPHAN_ASSET)
    if (
        isinstance(because, dict)
        and because.get("code") in ORPHAN_REASONS
        and isinstance(because.get("detail", ""), str)
        and (asset is None or isinstance(asset, str))
    ):
        return asset, because["code"], because.get("detail", "")
    return None, "earlier-run", "recorded by an earlier run without its reason"


def orphan_phrase(n: int, code: str, detail: str) -> str:
    """``n`` orphans of one reason as the run's last lines count them: ``2 outputs of assets no longer in the
    config``, ``4 outputs at their assets' names before output.names: stem -> path``."""
    outputs = f"{n} output" + "s" * (n != 1)
    if code == "asset-removed":
        return f"{outputs} of {'assets' if n != 1 else 'an asset'} no longer in the config"
    if code == "names-changed":
        whose = "their assets'" if n != 1 else "its asset's"
        return f"{outputs} at {whose} names before {detail}"
    if code == "kind-unwanted":
        return f"{outputs} of a kind the config no longer asks for ({detail})"
    if code == "run-output-unwanted":
        return f"{outputs} the config no longer asks for ({detail})"
    return f"{outputs} an earlier run left (its reason not recorded)"


def orphan_line(o: dict) -> str:
    """One orphan as a dry run names it: ``spot.swpm: output of an asset no longer in the config
    (meshes/spot.obj)``, ``scene.swpm: output of m/scene.obj at its name before output.names: stem ->
    path``."""
    asset, code, detail = o.get(ORPHAN_ASSET), o[ORPHAN_BECAUSE]["code"], o[ORPHAN_BECAUSE]["detail"]
    if code == "asset-removed":
        return f"{o['path']}: output of an asset no longer in the config ({asset})"
    if code == "names-changed":
        return f"{o['path']}: output of {asset} at its name before {detail}"
    if code == "kind-unwanted":
        return f"{o['path']}: output of {asset} of a kind the config no longer asks for ({detail})"
    if code == "run-output-unwanted":
        return f"{o['path']}: run output the config no longer asks for ({detail})"
    return f"{o['path']}: output an earlier run left (its reason not recorded)"


def _orphaned_outputs(
    cfg: Config, out_dir: Path, manifest: dict, items: list, verify: bool = False
) -> list[tuple[Path, dict]]:
    """The recorded outputs (path, record) of the manifest's assets that are not among ``items`` (no longer
    in the config) and of its ``orphaned_outputs`` (left by earlier runs without ``prune``), still as
    recorded (:func:`_checked_output`: a file changed since is not the run's; its stat fields recorded
    anew when it was hashed), less any file this run's assets write or read (an earlier output used as a
    stage, or a layer a stage uses) and the config. Each record names its asset and why it is left
    (:func:`_orphan_record`; an ``orphaned_outputs`` entry keeps what it recorded)."""
    current = {it.asset.id for it in items}
    recorded: list[tuple[Any, tuple[str | None, str, str]]] = [
        (o, (aid, "asset-removed", ""))
        for aid, rec in sorted(manifest.get("assets", {}).items())
        if aid not in current and isinstance(rec, dict) and isinstance(rec.get("outputs"), dict)
        for o in rec["outputs"].values()
    ]
    if isinstance(manifest.get(ORPHANED), list):
        recorded += [
            (o, _recorded_because(o) if isinstance(o, dict) else (None, "", "")) for o in manifest[ORPHANED]
        ]
    if isinstance(manifest.get(RUN_OUTPUTS), dict):  # a scene or report the config no longer asks for
        recorded += [
            (o, (None, "run-output-unwanted", f"{kind}: false"))
            for kind, o in sorted(manifest[RUN_OUTPUTS].items())
            if kind in _RUN_OUTPUT_DEFAULTS and not _asks_for(cfg, kind)
        ]
    if not recorded:
        return []  # the usual run: no file stat'ed for the guard below
    keep = _files_kept(cfg, out_dir, items)
    found, seen = [], set()
    for o, (asset, code, detail) in recorded:
        if not isinstance(o, dict) or not isinstance(o.get("path"), str) or "\0" in o["path"]:
            continue  # (a hand-edited manifest: a NUL byte would raise in every path call)
        path = out_dir / o["path"]
        # a recorded path that leaves output.dir (a hand-edited manifest) is never touched
        if path.resolve().parent != out_dir.resolve() or _file_key(path) in keep or path in seen:
            continue
        checked = _checked_output(path, o, verify)
        if checked is not None:
            seen.add(path)
            found.append((path, _orphan_record(checked, asset, code, detail)))
    return found


def _files_kept(cfg: Config, out_dir: Path, items: list) -> set[tuple]:
    """The files (:func:`_file_key`) no output of a removed asset or kind may be taken for: those this run's
    assets write or read (an earlier output used as a stage, or a layer a stage uses) and the config."""
    keep = {_file_key(p) for p in planned_outputs(cfg, out_dir, [it.asset for it in items])}
    return keep | {_file_key(p) for p in [cfg.path, *(p for it in items for p in it.inputs)]}


def _dropped_outputs(
    out_dir: Path,
    previous: dict | None,
    built: dict,
    verify: bool = False,
    asset: str | None = None,
    moved: str = "",
) -> list[tuple[Path, dict]]:
    """The outputs of an asset's previous build (``previous``, its record) that its new one (``built``)
    does not write, still as recorded, as :func:`_orphaned_outputs` gives them: the new record does not list
    them, so the run names them (and ``prune`` deletes them) as it does a removed asset's. Each is named as
    ``asset``'s: ``names-changed`` where the new build writes its kind under another name (``moved``: what
    moved it, :func:`.rules._names_moved`), else ``kind-unwanted`` (``swpm: false`` since)."""
    if previous is None:
        return []
    written = {kind: o["path"] for kind, o in built.get("outputs", {}).items()}
    found = []
    for kind, o in previous.get("outputs", {}).items():
        checked = None if o["path"] in written.values() else _checked_output(out_dir / o["path"], o, verify)
        if checked is not None:
            if kind in written:
                record = _orphan_record(checked, asset, "names-changed", moved)
            else:
                record = _orphan_record(checked, asset, "kind-unwanted", f"{kind}: false")
            found.append((out_dir / o["path"], record))
    return found


def _left_by_rebuilds(cfg: Config, out_dir: Path, items: list, todo: list) -> list[dict]:
    """The recorded outputs of the assets ``todo`` that their rebuild does not write, still as recorded, each
    named as its asset's, with why it is left (:func:`.outputs._dropped_outputs`, as the run finds them once
    each is built), less the files this run's assets write or read."""
    wanted = _wanted_outputs(cfg)
    found: list[dict] = []
    keep = None
    for it in todo:
        if not isinstance(it.previous, dict):
            continue
        stem = it.asset.output_stem
        built = {"outputs": {k: {"path": f"{stem}{OUTPUT_SUFFIXES[k]}"} for k in wanted}}
        moved = _names_moved(cfg, it.asset, it.previous)
        for path, o in _dropped_outputs(out_dir, it.previous, built, asset=it.asset.id, moved=moved):
            keep = _files_kept(cfg, out_dir, items) if keep is None else keep
            if _file_key(path) not in keep:
                found.append(o)
    return found


def _keep_previous(out_dir: Path, previous: dict | None, failed: dict, verify: bool = False) -> dict | None:
    """The record of an asset whose rebuild failed (``failed``, the worker's record).

    When the asset was built before and its outputs are all still as recorded (:func:`_checked_output`),
    its previous build is kept: the returned record is the previous one, untouched but for ``last_failure``
    (the failure's error, traceback, digest and seconds) and the stat fields of outputs hashed to be
    checked (its ``inputs`` stay: their stat goes with its input digest, not the failed attempt's), so the
    manifest, the scene and the outputs still serve the last good build and the next run tries again.
    Otherwise None: the failed record replaces the previous one, and those of its outputs still as recorded
    are deleted, so no output is left that the manifest does not list (a file changed since is not the
    run's to delete)."""
    if previous is None or record_problem(previous) is not None or previous.get("status") != "built":
        return None  # (a record the run does not write, hand-edited, names no file to keep or delete)
    outputs = previous.get("outputs", {})
    checked = {kind: _checked_output(out_dir / o["path"], o, verify) for kind, o in outputs.items()}
    if any(o is None for o in checked.values()):
        for o in checked.values():
            if o is not None:
                (out_dir / o["path"]).unlink(missing_ok=True)
        return None
    keys = ("error", *PROBLEM_KEYS, "traceback", "digest", "input_digest", "seconds")
    failure = {k: failed[k] for k in keys if k in failed}
    kept = {k: v for k, v in previous.items() if k != "last_failure"}
    if outputs:
        kept["outputs"] = checked
        layer = checked.get("usd")
        with_units = _layer_with_units(out_dir, layer) if layer is not None else None
        if with_units is not None and with_units is not layer:  # (for the scene: none read, it has none)
            kept["outputs"] = {**checked, "usd": with_units}
    return {**kept, "last_failure": failure}
