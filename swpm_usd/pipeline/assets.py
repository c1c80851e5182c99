"""Asset discovery and rule matching for the pipeline.

An asset is a mesh file matched by a glob, or a Mesh prim of a USD stage (its instance count comes from
the composed stage: instanceable prims sharing a prototype, and PointInstancer ids). Rules are tried in
order; the first whose ``match`` holds wins, a rule without ``match`` matches everything, and when no rule
matches, ``defaults`` apply: the matching, an asset's treatment and its digest are :mod:`.treatment`'s
(re-exported here). Besides discovery, this module lists the files an asset is built from (a glTF's buffers,
a USD stage's layers) and hashes them (:func:`hash_inputs`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import struct
import time
import unicodedata
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import first_few
from .config import Config
from .treatment import _MAXIMA as _MAXIMA  # (re-exported, as the names below)
from .treatment import _MINIMA as _MINIMA
from .treatment import canonical_treatment as canonical_treatment
from .treatment import checks_no_stricter as checks_no_stricter
from .treatment import checks_of as checks_of
from .treatment import match_rule as match_rule
from .treatment import rule_checks as rule_checks
from .treatment import treatment_digest as treatment_digest


@dataclass
class Asset:
    id: str  # stable name: path relative to the config, plus ":/prim/path" for stage assets
    path: Path
    prim: str | None = None
    instances: int = 1
    tags: dict[str, Any] = field(default_factory=dict)
    source_index: int = 0  # which entry of `assets` found it
    #: the base of its output names under ``output.names: path`` (:func:`path_name`); None: the file's stem
    path_name: str | None = None

    @property
    def file_id(self) -> str:
        """Its id without ``:<prim>``: its file's path relative to the config (a file's name may hold ':'
        itself, ``x:y.obj``, so the prim is cut by its length)."""
        return self.id[: -len(self.prim) - 1] if self.prim is not None else self.id

    @property
    def output_stem(self) -> str:
        """The name of its outputs without their suffix (``rock`` for ``rock.swpm``; a stage's prim after the
        stage's name and ``__``)."""
        base = self.path.stem if self.path_name is None else self.path_name
        if self.prim is None:
            return base
        return f"{base}__{self.prim.strip('/').replace('/', '_')}"


#: the values of ``output.names``: outputs named by the file's stem (the default), or by its path
OUTPUT_NAMES = ("stem", "path")
#: what joins the folders of an output name under ``output.names: path`` (``props--chair--scene.swpm``):
#: legal in a file name everywhere, never made by the prim separator ``__``, and not ``.``, which would
#: read as a suffix (the worker names a USD layer's root prim by the name up to its first dot)
PATH_NAME_SEPARATOR = "--"


def _glob_root(pattern: str) -> tuple[str, ...]:
    """The fixed folders a glob starts from: its parts before the first holding a wildcard (``*?[``); a
    pattern without one (a file's path) starts from that file's folder."""
    parts = Path(pattern).parts
    fixed = []
    for part in parts:
        if any(c in part for c in "*?["):
            return tuple(fixed)
        fixed.append(part)
    return tuple(fixed[:-1])


def path_name(file: Path, root: Path) -> str:
    """The base of a glob-matched ``file``'s output names under ``output.names: path``: its path relative to
    ``root`` (the glob's fixed folder, :func:`_glob_root`), without its suffix, its folders joined by
    :data:`PATH_NAME_SEPARATOR` (``library/props/chair/scene.gltf`` under ``library``:
    ``props--chair--scene``); its stem when it is not under ``root``."""
    try:
        rel = file.relative_to(root)
    except ValueError:
        return file.stem
    return PATH_NAME_SEPARATOR.join((*rel.parent.parts, rel.stem))


def output_names(cfg: Config) -> str:
    """The config's ``output.names``: ``"stem"`` (the default) or ``"path"``."""
    out = cfg.data.get("output")
    return "path" if isinstance(out, dict) and out.get("names", "stem") == "path" else "stem"


def names_by_path(cfg: Config) -> bool:
    """Does the config name outputs by the asset's path (``output.names: path``), not its stem?"""
    return output_names(cfg) == "path"


def file_digest(paths: list[Path]) -> str:
    """The digest of an asset's input files (their names and bytes, in order): :func:`hash_inputs`'s."""
    return hash_inputs(paths)[0]


def hash_inputs(paths: list[Path]) -> tuple[str, list[dict[str, Any]]]:
    """The digest of an asset's input files and, for each, its manifest entry: ``path``, and the ``size``
    and :data:`.file_hash.STAT_KEYS` of the bytes hashed (the stat taken through the descriptor read, before
    the read) with ``hashed_ns``, the time just before that stat (the runner's guard against a "racily
    clean" file: :func:`.inputs._inputs_unchanged`); the path alone for a file that changed while it was
    read, which the next run hashes again."""
    from .file_hash import stat_fields, update_with_stat

    h = hashlib.sha256()
    entries: list[dict[str, Any]] = []
    for p in paths:
        h.update(str(p.name).encode())
        hashed_ns = time.time_ns()
        st = update_with_stat(h, p)
        entry: dict[str, Any] = {"path": str(p)}
        if st is not None:
            entry.update(size=st.st_size, **stat_fields(st), hashed_ns=hashed_ns)
        entries.append(entry)
    return h.hexdigest(), entries


#: a .glb's header (magic, version, length) and its first chunk's (length, type): its JSON
_GLB_HEADER = struct.Struct("<4sIIII")
_GLB_JSON = 0x4E4F534A


def _gltf_document(path: Path) -> Any:
    """The JSON document of a ``.gltf``, or the JSON chunk of a ``.glb`` (its header and that chunk read
    alone, not its binary chunk); None for another file, or one that is neither (its load fails)."""
    suffix = path.suffix.lower()
    try:
        if suffix == ".gltf":
            return json.loads(path.read_bytes())
        if suffix != ".glb":
            return None
        with open(path, "rb") as f:
            head = f.read(_GLB_HEADER.size)
            if len(head) < _GLB_HEADER.size:
                return None
            magic, _, length, chunk_length, chunk_type = _GLB_HEADER.unpack(head)
            if magic != b"glTF" or chunk_type != _GLB_JSON or chunk_length > length:
                return None
            return json.loads(f.read(chunk_length))
    except (OSError, ValueError, RecursionError):
        return None


def _gltf_buffers(path: Path) -> list[Path]:
    """The files beside a ``.gltf`` or ``.glb`` that hold its vertices and triangles: those its ``buffers``
    name by a ``uri`` (not a base64 ``data:`` one; a .glb's own binary chunk is the buffer without one),
    which the loader reads, in its folder, by the names of :func:`swpm_usd.io.gltf_prepare.uri_names` (the
    uri percent-decoded, then as written; each without a leading ``/``, or by its last part): every one of
    those found, so a change to any is a change to the asset; none for another file, or one whose JSON does
    not read (its load fails)."""
    return _gltf_buffer_files(path)[0]


def _gltf_buffer_files(path: Path) -> tuple[list[Path], bool]:
    """:func:`_gltf_buffers`, and whether each buffer was found by the first of its names the loader tries
    (its name percent-decoded, in the folder): when one was found by a later name (``bin/data.bin`` read from
    ``data.bin``), a file written later under an earlier one is what the loader reads, with every file
    listed unchanged, so the list holds only while it is read again (:data:`LISTED_SUFFIXES`). A glTF
    whose JSON did not read (being written, or unreadable a moment) is not settled either: should the
    loader read it, the list is its alone."""
    from ..io.gltf_prepare import uri_names

    doc = _gltf_document(path)
    if doc is None:
        return [], path.suffix.lower() not in (".gltf", ".glb")
    buffers = doc.get("buffers") if isinstance(doc, dict) else None
    if not buffers:
        return [], True
    found: list[Path] = []
    settled = True
    for b in buffers if isinstance(buffers, list) else []:
        uri = b.get("uri") if isinstance(b, dict) else None
        if not isinstance(uri, str) or "base64," in uri:
            continue
        first = True  # (the first name of this uri inside the folder, the loader's first try)
        for name in uri_names(uri):  # (percent-decoded first, as the loader reads it)
            f = path.parent / name
            try:
                inside = f.resolve().is_relative_to(path.parent.resolve())
                if not (name and inside):
                    continue
                exists = f.is_file()
                if exists and f not in found:
                    found.append(f)
            except (OSError, ValueError):
                continue
            if first and not exists:
                settled = False
            first = False
    return found, settled


def _used_layers(stage) -> list[Path]:
    """The files of the layers ``stage`` uses, sorted (GetUsedLayers gives a set of layer handles in the
    order of their addresses, another in each process, and the inputs are hashed and compared with the
    record in their order; a layer in a package, ``a.usdz[b.usdc]``, is the package's file)."""
    from pxr import Ar

    return sorted(
        {
            Path(Ar.SplitPackageRelativePathOuter(layer.realPath)[0])
            for layer in stage.GetUsedLayers()
            if layer.realPath
        }
    )


def _usd_layers(path: Path) -> list[Path]:
    """The files other than ``path`` whose layers a USD file a glob matched uses (its references,
    sublayers, payloads), which the loader composes: a change to one is a change to the asset. None for
    another file, or one that does not open (its load fails)."""
    return _usd_layer_files(path)[0]


def _usd_layer_files(path: Path) -> tuple[list[Path], bool]:
    """:func:`_usd_layers`, and whether the file opened (else, should the loader open it a moment later,
    the list of the file alone is not its inputs: not settled, see :func:`discover`)."""
    from ..io import _USD_SUFFIXES

    if path.suffix.lower() not in _USD_SUFFIXES:
        return [], True
    from ..usd.probe import checked, used_layers

    with checked(path) as probed:
        if probed is not None:  # (a crate file that crashes usd-core: not opened here, the worker fails it)
            return [], False
        # a file the probe opened (a crate, or a text root naming one) is not opened again here: the probe
        # listed its layers (a 12 MB crate asset's planning parsed it twice, the probe's and this one)
        used = used_layers(path)
        if used is not None:  # (a file, probed clean: its path resolves, where a link loop's raised)
            here = path.resolve()
            return [p for p in map(Path, used) if p.resolve() != here], True
        try:
            from pxr import Usd

            stage = Usd.Stage.Open(str(path))
        except Exception:  # noqa: BLE001 - the worker's load reports it, located
            return [], False
    if stage is None:
        return [], False
    here = path.resolve()
    return [p for p in _used_layers(stage) if p.resolve() != here], True


def _stage_assets(cfg: Config, index: int, stage_path: Path) -> tuple[list[Asset], list[Path]]:
    from pxr import Usd, UsdGeom

    from ..io.usd_loader import _not_rendered
    from ..usd.probe import checked

    with checked(stage_path) as probed:  # (a crate file that would crash this process: not opened here)
        if probed is not None:
            raise OSError(probed.message.removeprefix(f"{stage_path}: "))
        stage = Usd.Stage.Open(str(stage_path))
    if stage is None:
        raise OSError("the stage does not open")
    counts: dict[str, int] = {}
    first_path: dict[str, str] = {}
    tags: dict[str, dict] = {}
    pred = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
    time = Usd.TimeCode.EarliestTime()  # (the loader's)
    instancer_counts: dict[str, int] = {}
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), pred):
        if prim.IsA(UsdGeom.PointInstancer):
            inst = UsdGeom.PointInstancer(prim)
            targets = inst.GetPrototypesRel().GetTargets()
            ids = inst.GetProtoIndicesAttr().Get() or []
            for i, t in enumerate(targets):
                instancer_counts[str(t)] = instancer_counts.get(str(t), 0) + sum(1 for x in ids if x == i)
        if not prim.IsA(UsdGeom.Mesh):
            continue
        if _not_rendered(prim, time) is not None:  # (invisible, guide, proxy: the loader leaves them out)
            continue
        key = str(prim.GetPrimInPrototype().GetPath()) if prim.IsInstanceProxy() else str(prim.GetPath())
        counts[key] = counts.get(key, 0) + 1
        first_path.setdefault(key, str(prim.GetPath()))
        tags.setdefault(key, dict(prim.GetCustomData()))
    # meshes under a PointInstancer prototype are drawn once per instancer id, not as themselves
    for proto, n in instancer_counts.items():
        for key in counts:
            if key == proto or key.startswith(proto + "/"):
                counts[key] = n
    rel = stage_path.relative_to(cfg.base) if stage_path.is_relative_to(cfg.base) else stage_path
    assets = [
        Asset(f"{rel.as_posix()}:{first_path[k]}", stage_path, first_path[k], counts[k], tags[k], index)
        for k in sorted(counts)
    ]
    return assets, _used_layers(stage)


def _first_match(
    cfg: Config,
    matched: dict[tuple, tuple[int, int]],
    key: tuple,
    index: int,
    name: str,
    instances: int,
    problems: list[str],
) -> bool:
    """Is this the first entry of ``assets`` to find the file (prim) ``key``? One file is one asset, built
    once: a later entry that finds it again with the same settings is skipped, and one with other settings
    (``instances``) is a problem, located at it."""
    if key not in matched:
        matched[key] = (index, instances)
        return True
    first, first_instances = matched[key]
    if first_instances != instances and first != index:
        problems.append(
            f"{cfg.where(('assets', index))}: {name} is also matched by $.assets[{first}] with "
            f"instances={first_instances}, here instances={instances}: one file is one asset; "
            f"narrow one of the two so each file is matched once"
        )
    return False


#: the files whose inputs are listed by reading them (:func:`discover`): a glTF names its buffer files, a
#: USD file the layers it uses (opening one as a stage: about 4 ms for a small .usda)
LISTED_SUFFIXES = (".gltf", ".glb", ".usd", ".usda", ".usdc", ".usdz")


def output_dir(cfg: Config) -> Path:
    """The config's ``output.dir``, as a path (relative to the config's folder)."""
    return cfg.base / cfg.data["output"]["dir"]


def _under(path: Path, folder: Path, real: dict[Path, str]) -> bool:
    """Is ``path`` in ``folder`` or below it (its folder resolved: a link to a file elsewhere that sits in
    ``folder`` is in it; ``folder`` a link itself is the folder it names)? ``real`` caches the folders'
    real paths."""
    try:
        for f in (path.parent, folder):
            if f not in real:
                real[f] = os.path.realpath(f)
        return Path(real[path.parent]).is_relative_to(real[folder])
    except (OSError, ValueError):
        return False


def _shown(cfg: Config, path: Path) -> str:
    """``path`` relative to the config's folder when it is under it, else as it is."""
    try:
        return path.relative_to(cfg.base).as_posix()
    except ValueError:
        return str(path)


def discover(
    cfg: Config,
    recorded_outputs: Iterable[Path] = (),
    listed: Callable[[str, Path], list[Path] | None] | None = None,
    settled: set[str] | None = None,
    aliases: list[str] | None = None,
) -> tuple[list[Asset], dict[str, list[Path]], list[str]]:
    """Every asset of the config, the files each depends on, and semantic problems (located). A file (or a
    stage's prim) matched by several entries of ``assets`` is one asset, found by the first of them. A
    glob never matches a file in ``output.dir`` (or below it): the run's outputs are not its inputs. When
    ``output.dir`` holds the config (``.``, where the inputs are too), it never matches one of the
    ``recorded_outputs`` (those the manifest lists) instead.

    A glob-matched file's inputs are the file with the buffer files a glTF names or the layers a USD file
    uses (each read to list them), unless ``listed(asset id, file)`` gives them: the runner's list of the
    asset's manifest record, when those files are all as recorded (:func:`.inputs._listed_inputs`). The
    ids of those of :data:`LISTED_SUFFIXES` whose list holds while the files in it are unchanged (taken
    from ``listed``, or read with every glTF buffer found by its name as written: a USD file with a layer
    it cannot open does not load) are added to ``settled``: their records may keep the list for reuse.
    A matched path that is another matched path's file (a link to it) is that asset: ``aliases`` gets a
    warning naming both (located), as the path is no asset of its own."""
    # (here: the CLI's --help and config checks import no mesh code)
    from ..io import _USD_SUFFIXES, SUPPORTED_SUFFIXES

    assets: list[Asset] = []
    inputs: dict[str, list[Path]] = {}
    problems: list[str] = []
    matched: dict[tuple, tuple[int, int]] = {}
    matched_as: dict[Path, str] = {}  # a glob-matched file's real path -> the id of its asset
    out_dir = output_dir(cfg)
    folders: dict[Path, str] = {}  # a matched file's folder -> its real path (one realpath a folder)
    holds_config = _under(cfg.path, out_dir, folders)  # (output.dir ".": the inputs are there too)
    # (their real paths only where they are looked up: 10,000 assets' 20,000 outputs, a second a run)
    recorded_outputs = {os.path.realpath(p) for p in recorded_outputs} if holds_config else set()
    under: dict[Path, bool] = {}  # a matched file's folder -> is it output.dir or in it
    by_path = names_by_path(cfg)

    def is_output(p: Path) -> bool:
        """Is ``p``, a file a glob matched, the run's and not an input: in output.dir or below it, and when
        output.dir holds the config (``.``: the inputs are there too) one of the recorded outputs?"""
        if p.parent not in under:  # (the folder decides: one answer a folder)
            under[p.parent] = _under(p, out_dir, folders)
        return under[p.parent] and (not holds_config or os.path.realpath(p) in recorded_outputs)

    def realpath(p: Path) -> str:
        """``os.path.realpath(p)``, by its folder's (cached) when ``p`` is not a link itself."""
        if p.parent in folders and not p.is_symlink():
            return os.path.join(folders[p.parent], p.name)
        return os.path.realpath(p)

    for i, src in enumerate(cfg.data["assets"]):
        if "glob" in src:
            where = cfg.where(("assets", i, "glob"))
            if not src["glob"] or Path(src["glob"]).is_absolute():
                problems.append(
                    f"{where}: a glob must be a non-empty pattern relative to the config's folder"
                )
                continue
            dangling: set[Path] = set()
            fixed = _glob_root(src["glob"])
            try:
                # (a dangling link of a mesh type too: its asset fails, named, rather than vanish)
                files = []
                for p in cfg.base.glob(src["glob"]):
                    if p.is_file():
                        files.append(p)
                    elif p.is_symlink() and not p.exists() and p.suffix.lower() in SUPPORTED_SUFFIXES:
                        files.append(p)
                        dangling.add(p)
                files.sort()
            except (ValueError, NotImplementedError, OSError) as exc:
                problems.append(f"{where}: unusable glob: {exc}")
                continue
            # the run's own outputs are never assets: a glob reaching into output.dir (``**/*``) would take
            # them as inputs on the next run (its .usdc layers, scene.usda), which then overwrite themselves
            flags = {p: is_output(p) for p in files}
            outputs = [p for p in files if flags[p]]
            files = [p for p in files if not flags[p]]
            # a glob's assets are its mesh files: not the config, textures, .mtl or notes it also matches
            found = [p for p in files if p.suffix.lower() in SUPPORTED_SUFFIXES]
            if not files and outputs:
                problems.append(
                    f"{where}: the glob matches only files in output.dir ({_shown(cfg, out_dir)}), which are "
                    "never assets: the run writes there"
                )
            elif not files:
                problems.append(f"{where}: the glob matches no file")
            elif not found:
                others = [p.relative_to(cfg.base).as_posix() for p in files]
                shown = first_few(others)
                problems.append(
                    f"{where}: the glob matches no mesh file ({len(others)} file"
                    f"{'s' if len(others) > 1 else ''} of another type: {shown}); mesh files end in "
                    f"{' '.join(SUPPORTED_SUFFIXES)}"
                )
            same: list[tuple[str, str]] = []  # (a matched path, the asset it is one file with)
            # USD files whose layers are read below, after their probes (several at once: check_many)
            deferred: list[tuple[str, Path, list[Path], bool]] = []
            for p in found:
                rel = p.relative_to(cfg.base).as_posix()
                instances = int(src.get("instances", 1))
                # (realpath: a link in a loop, which fails as its asset, is a RuntimeError to resolve(); a
                # dangling link is itself, its folder resolved: two to one missing file fail, each named)
                real = Path(os.path.join(realpath(p.parent), p.name) if p in dangling else realpath(p))
                if not _first_match(cfg, matched, (real, None), i, rel, instances, problems):
                    if matched_as[real] != rel:
                        same.append((rel, matched_as[real]))
                    continue
                matched_as[real] = rel
                named = path_name(p, cfg.base.joinpath(*fixed)) if by_path else None
                assets.append(Asset(rel, p, None, instances, {}, i, named))
                known = listed(rel, p) if listed is not None else None
                settles = known is not None
                if known is None:
                    buffers, buffers_settled = _gltf_buffer_files(p)
                    if p.suffix.lower() in _USD_SUFFIXES:
                        inputs[rel] = []  # (its place: filled below)
                        deferred.append((rel, p, buffers, buffers_settled))
                        continue
                    known, settles = [p, *buffers], buffers_settled
                inputs[rel] = known
                if settled is not None and settles and p.suffix.lower() in LISTED_SUFFIXES:
                    settled.add(rel)
            done: dict[int, tuple[list[Path], bool]] = {}  # (deferred's index -> its _usd_layer_files)
            if deferred:
                from ..usd.probe import check_many

                # the crate files among them are probed before one is opened here, up to a core each at
                # once (one after another, 2,000 new .usdc assets took 20 s): the answers are then known. A
                # text root naming no crate file is opened as it is found so (its text parsed once, not again
                # here: the planning of one 3.8 MB .usda asset, 3.28 s median was 1.76 s)
                roots = [p for _, p, _, _ in deferred]
                check_many(
                    roots,
                    opened=lambda i, roots=roots, done=done: done.update({i: _usd_layer_files(roots[i])}),
                )
            for j, (rel, p, buffers, buffers_settled) in enumerate(deferred):
                layers, layers_settled = done[j] if j in done else _usd_layer_files(p)
                inputs[rel] = [p, *buffers, *layers]
                if (
                    settled is not None
                    and buffers_settled
                    and layers_settled
                    and p.suffix.lower() in LISTED_SUFFIXES
                ):
                    settled.add(rel)
            if aliases is not None and len(same) == 1:
                ((rel, first),) = same
                aliases.append(
                    f"{where}: {rel} and {first} are one file (a link to the other or to one file), one "
                    f"asset built as {first}: {rel} has no outputs of its own (copy the file to build it "
                    "apart)"
                )
            elif aliases is not None and same:  # (one warning: a linked folder doubles every file in it)
                shown = first_few([f"{rel} as {first}" for rel, first in same[:4]])
                aliases.append(
                    f"{where}: {len(same)} matched paths are each one file with another (a link to it or "
                    "to one file, a linked folder), one asset built under the other's name, and have no "
                    f"outputs of their own: {shown} (copy a file to build "
                    "it apart)"
                )
        else:
            given = cfg.base / src["stage"]
            stage_path = None
            try:
                # (in the try: a link in a loop is a RuntimeError to resolve(), reported as the stage's)
                stage_path = given.resolve()
                # its prims' ids and outputs named after the stage as written, as a glob's files are: a link
                # (scene.usda -> versions/scene_v3.usda) keeps them, the scene's prims and the rules' paths
                # as it is pointed at the next version (one with `..` in it: its real path, as before)
                named = given if ".." not in given.parts else stage_path
                found, used = _stage_assets(cfg, i, named)
            except Exception as exc:  # noqa: BLE001 - any pxr failure is reported, located
                from ..errors import tf_message

                if stage_path is None:  # (its path does not resolve: "Symlink loop from ...")
                    msg = str(exc).strip() or type(exc).__name__
                elif not stage_path.exists():
                    msg = "no such file"
                else:  # (usd-core's message, without its C++ function, file and line)
                    msg = tf_message(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
                problems.append(
                    f"{cfg.where(('assets', i, 'stage'))}: cannot open stage {src['stage']}: {msg}"
                )
                continue
            if not found:
                problems.append(
                    f"{cfg.where(('assets', i, 'stage'))}: the stage has no Mesh prims a renderer draws "
                    "(invisible, guide and proxy ones are not assets)"
                )
            for a in found:
                if not _first_match(cfg, matched, (stage_path, a.prim), i, a.id, a.instances, problems):
                    continue
                assets.append(a)
                inputs[a.id] = used
    seen: dict[str, Asset] = {}
    # (a stem folded as a case-insensitive filesystem folds it -> the first asset and its stem)
    folded: dict[str, tuple[Asset, str]] = {}
    # two stage entries of one file stem and prim paths: (first entry, later entry) -> the stems both write,
    # said once a pair of entries (two sets of 1,000 prims under /World: 1,000 problems were listed)
    stage_pairs: dict[tuple[int, int], list[str]] = {}
    # (a run writing no outputs, swpm and usd off, names no file after an asset: any name does)
    writes = bool(cfg.data["output"].get("swpm", True) or cfg.data["output"].get("usd", False))
    for a in assets:
        stem = a.output_stem
        where = cfg.where(("assets", a.source_index))
        if stem in seen and seen[stem].id != a.id and _stages_of_one_stem(cfg, a, seen[stem]):
            stage_pairs.setdefault((seen[stem].source_index, a.source_index), []).append(stem)
        elif stem in seen and seen[stem].id != a.id:
            problems.append(
                f"{where}: {a.id} and {seen[stem].id} would both write {stem}.swpm"
                f"{_names_hint(cfg, a, seen[stem]) or _suffix_hint(a, seen[stem])}"
            )
        elif _folded(stem) in folded and folded[_folded(stem)][1] != stem:
            other, other_stem = folded[_folded(stem)]
            same_text = unicodedata.normalize("NFC", stem) == unicodedata.normalize("NFC", other_stem)
            differ = "Unicode normalization" if same_text else "case"
            problems.append(
                f"{where}: {a.id} and {other.id} would both write {stem}.swpm on a case-insensitive "
                f"filesystem (macOS, Windows): {stem}.swpm and {other_stem}.swpm differ only in {differ}"
                f"{_names_hint(cfg, a, other) or '; rename one'}"
            )
        if writes and len(os.fsencode(stem)) > LONGEST_STEM:
            problems.append(f"{where}: {a.id}: {_too_long(cfg, a, stem)}")
        seen[stem] = a
        folded.setdefault(_folded(stem), (a, stem))
    for (first, later), stems in stage_pairs.items():
        files = [cfg.data["assets"][i]["stage"] for i in (later, first)]
        # (FILE:LINE:COL of the first entry: cut at the last ": ", a path may hold one, $.assets[i] none)
        at = cfg.where(("assets", first)).rsplit(": ", 1)[0]
        more = f" and {len(stems) - 1} more output name{'s' * (len(stems) > 2)}" if len(stems) > 1 else ""
        problems.append(
            f"{cfg.where(('assets', later))}: stage {files[0]} and stage {files[1]} ($.assets[{first}], "
            f"{at}) would both write {stems[0]}.swpm{more} ({len(stems)} prim path"
            f"{'s' * (len(stems) > 1)} in both): a stage's outputs are named by its file's stem and the prim "
            "under either output.names, so two stages must differ in their file's stem or their prim "
            "paths; rename one stage file (or give a stage of another name that sublayers it)"
        )
    return assets, inputs, problems


def _stages_of_one_stem(cfg: Config, a: Asset, b: Asset) -> bool:
    """Are ``a`` and ``b`` prims of two stage entries' files of one stem (named alike: a stage's outputs are
    named by its stem under either ``output.names``)?"""
    return (
        a.prim is not None
        and b.prim is not None
        and a.source_index != b.source_index
        and all("stage" in cfg.data["assets"][x.source_index] for x in (a, b))
        and a.path.stem == b.path.stem
        and a.path != b.path
    )


def _given_by_path(cfg: Config, a: Asset) -> bool:
    """Was ``a`` found by a glob without a wildcard (a file's path)?"""
    src = cfg.data["assets"][a.source_index]
    return "glob" in src and not any(c in src["glob"] for c in "*?[")


def _names_hint(cfg: Config, a: Asset, b: Asset) -> str:
    """What to do about two assets whose outputs would have one name: under ``output.names: stem``, when
    their names by path differ (files of one name in different folders, ``props/chair/scene.gltf`` and
    ``props/table/scene.gltf``, which a library cannot rename), ``output.names: path``, with the names it
    gives them; under ``path``, for two files each given by its path (named by its stem), one glob over both.
    "" when neither helps (the caller's own words stand)."""
    if names_by_path(cfg):
        # (a glob without a wildcard starts from its file's folder: such a file is named by its stem)
        if all(_given_by_path(cfg, x) for x in (a, b)) and a.path.parent != b.path.parent:
            return (
                "; each is given by its path, so named by its stem under output.names: path: match both "
                "with one glob from a folder above them, or rename one"
            )
        return ""
    by_path = []
    for x in (a, b):
        src = cfg.data["assets"][x.source_index]
        root = cfg.base.joinpath(*_glob_root(src["glob"])) if "glob" in src else x.path.parent
        by_path.append(dataclasses.replace(x, path_name=path_name(x.path, root)).output_stem)
    if _folded(by_path[0]) == _folded(by_path[1]):
        return ""
    return (
        f"; output.names: path names outputs by their path under the glob's fixed folder: {by_path[0]}.swpm "
        f"and {by_path[1]}.swpm (or rename one)"
    )


#: the longest output name (without ``.swpm``) the run can write, in bytes: a file name stops at 255 bytes
#: (ext4, XFS, APFS), and the longest name a run gives an output's file is the one it keeps the previous
#: build aside under, 24 bytes longer (``.<stem>.swpm.XXXXXXXX.prev.tmp``, :func:`..fileio.keep_aside`).
#: A longer name built the mesh, then failed its asset (``OUTPUT_UNWRITABLE``, "File name too long")
LONGEST_STEM = 255 - len("..swpm.XXXXXXXX.prev.tmp")


def _too_long(cfg: Config, a: Asset, stem: str) -> str:
    """Why ``a``'s outputs, named ``stem``, cannot be written, and what to do (names by path: a glob from a
    deeper folder, or stem names; a stage's prim: its path; else: rename the file)."""
    shown = f"{stem[:60]}...{stem[-30:]}" if len(stem) > 100 else stem
    if a.prim is not None:
        fix = "its outputs are named by its stage's file and its prim path: rename the stage or the prims"
    elif a.path_name is not None:
        fix = (
            "output.names: path joins every folder below the glob's fixed folder: start the glob from a "
            "deeper folder, or name outputs by their stem (output.names: stem)"
        )
    else:
        fix = "rename the file"
    return (
        f"its outputs would be named {shown}.swpm, {len(os.fsencode(stem))} bytes before .swpm, past the "
        f"{LONGEST_STEM} a name may have here (a file name stops at 255 bytes, and the run's temporary names "
        f"add 24); {fix}"
    )


def _suffix_hint(a: Asset, b: Asset) -> str:
    """What to do about two files of one folder and one name but their suffix (``cow.obj`` beside its export
    ``cow.glb``): outputs are named without the suffix under either ``output.names``, so neither helps (the
    error said nothing of what to do). "" for any other pair."""
    if a.prim is None and b.prim is None and a.path.parent == b.path.parent and a.path.stem == b.path.stem:
        return (
            f"; outputs are named without the file's suffix ({a.path.suffix} and {b.path.suffix} here) under "
            "either output.names: rename one, move it to a folder of its own, or narrow the glob to one "
            f'suffix ("*{b.path.suffix}")'
        )
    return ""


def _folded(name: str) -> str:
    """``name`` as a case-insensitive filesystem compares it: its case folded and, as macOS's APFS and HFS+
    compare names, its Unicode normalized (``é`` one code point or ``e`` and an accent)."""
    return unicodedata.normalize("NFC", name).casefold()
