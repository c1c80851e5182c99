"""Write progressive meshes to USD: an asset layer per mesh, discrete LOD variants and a UsdLod layer.

Asset layout (``write``)::

    /<Name>        Xform, defaultPrim, kind=component, assetInfo (name, identifier)
                   (references / instanceable prims target this)
      mesh         Mesh + SwpmMeshAPI: points in LOD order, LOD-0 topology, primvars, swpm:* buffers

With ``lods=n`` the mesh also gets a ``LOD`` variant set (``LOD0`` .. ``LOD{n-1}``, selection ``LOD0``) whose
variants hold the topology of ``n`` progressive LODs (chosen by triangle fraction or error, see
:func:`select_lods`) for tools that know neither UsdLod nor swpm; ``swpm:discreteLods`` names their
progressive LOD indices. :func:`write_usdlod` then writes a UsdLod layer over such an asset.
"""

from __future__ import annotations

import json
import math
import numbers
import os
import secrets
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from pxr import Gf, Kind, Sdf, Tf, Usd, UsdGeom, Vt

from ..encode.base import ProgressiveMesh
from ..encode.screen import screen_space_error
from ..errors import SwpmError, tf_message
from ..fileio import fill_layer_replacing
from ..format.layout import draw_index_width
from . import plugin
from .arrays import to_vt
from .names import valid_identifier
from .schema import COLLAPSE_FLAT, COLLAPSE_PREFIX, FORMAT_VERSION, SCHEMA_NAME, attr_name, camel

MESH_NAME = "mesh"
LOD_VARIANT_SET = "LOD"
#: the class prim of write_usdlod's layer holding each LOD item's source (the asset, its variant selected)
LOD_SOURCES = "sources"
_UNIFORM = Sdf.VariabilityUniform


class UsdWriteError(SwpmError):
    """The progressive mesh cannot be written to USD as asked."""

    code = "OUTPUT_UNSUPPORTED"


def _json_default(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


def _collapse_fields(buffers: dict[str, np.ndarray]) -> list[str]:
    """Buffers stored as columns of swpm:collapseRecords: 1-D collapse_* arrays of the record count."""
    names = [
        n
        for n, a in buffers.items()
        if n.startswith(COLLAPSE_PREFIX) and n not in COLLAPSE_FLAT and a.ndim == 1
    ]
    if not names:
        return []
    r = buffers[names[0]].shape[0]
    return [n for n in names if buffers[n].shape[0] == r and buffers[n].dtype.kind in "ui"]


def params_text(params: dict) -> str:
    """``swpm:params`` for ``params``: JSON that a reader accepts under the rules of a ``.swpm`` file's META
    (spec/format.md 3.1: no NaN or infinity, at most 128 deep, every number finite in binary64), else
    :class:`UsdWriteError`, so a stage is never written that :func:`.reader.read` refuses."""
    from ..format.meta import parse_meta_json

    try:
        text = json.dumps(params, sort_keys=True, default=_json_default, allow_nan=False)
        parse_meta_json(text)
    except (ValueError, RecursionError) as e:
        raise UsdWriteError(f"swpm:params is not JSON a reader accepts (spec/format.md 3.1): {e}") from e
    return text


def swpm_values(pm: ProgressiveMesh) -> dict[str, tuple[Sdf.ValueTypeName, Any]]:
    """Every swpm: attribute of ``pm``: name -> (Sdf type, value). Exactly what the prim stores."""
    buffers = {n: np.asarray(a) for n, a in pm.buffers().items()}
    fields = _collapse_fields(buffers)
    T = Sdf.ValueTypeNames
    out: dict[str, tuple[Sdf.ValueTypeName, Any]] = {
        "swpm:formatVersion": (T.Int, FORMAT_VERSION),
        "swpm:encoding": (T.Token, pm.encoding),
        # (the width an engine draws at: a strips' restart 0xFFFFFFFF copies to u16 as 0xFFFF while no vertex
        # id is 0xFFFF, so 4 only from 65,536 vertices on, whatever the file's width)
        "swpm:indexWidth": (T.Int, draw_index_width(pm.vertex_count, pm.restart_index)),
        "swpm:vertexCounts": to_vt("swpm:vertexCounts", pm.vertex_counts),
        "swpm:triangleCounts": to_vt("swpm:triangleCounts", pm.triangle_counts),
        "swpm:lodErrors": to_vt("swpm:lodErrors", pm.lod_errors),
        "swpm:params": (T.String, params_text(pm.params)),
        "swpm:attributeNames": (T.TokenArray, list(pm.attributes)),
        "swpm:attributeDtypes": (T.TokenArray, [np.asarray(a).dtype.name for a in pm.attributes.values()]),
        "swpm:bufferNames": (T.TokenArray, list(buffers)),
        "swpm:bufferDtypes": (T.TokenArray, [a.dtype.name for a in buffers.values()]),
        "swpm:bufferColumns": to_vt(
            "swpm:bufferColumns",
            np.array([a.shape[1] if a.ndim == 2 else 0 for a in buffers.values()], np.uint32),
        ),
    }
    vc = np.maximum(pm.vertex_counts.astype(np.float64), 1.0)
    band = np.floor(np.log2(max(float(vc[0]), 1.0) / vc)).astype(np.int64)
    starts = np.flatnonzero(np.r_[True, np.diff(band) != 0])
    bands = np.stack([starts, np.diff(np.r_[starts, band.shape[0]])], axis=1)
    out["swpm:streamingBands"] = to_vt("swpm:streamingBands", bands)
    if fields:
        table = np.stack([buffers[n] for n in fields], axis=1)
        out["swpm:collapseRecordFields"] = (T.TokenArray, [camel(n[len(COLLAPSE_PREFIX) :]) for n in fields])
        out["swpm:collapseRecords"] = to_vt("swpm:collapseRecords", table)
    for n, a in buffers.items():
        if n in fields:
            continue
        if a.ndim > 2:
            raise UsdWriteError(
                f"buffer {n!r} has shape {a.shape}; only 1-D and (n, k) buffers are supported"
            )
        out[attr_name(n)] = to_vt(attr_name(n), a)
    return out


def author_swpm(prim: Usd.Prim, pm: ProgressiveMesh) -> set[str]:
    """Apply SwpmMeshAPI to the Mesh ``prim`` and author every swpm: attribute explicitly; their names."""
    if not prim.IsA(UsdGeom.Mesh):
        raise UsdWriteError(
            f"{prim.GetPath()}: SwpmMeshAPI only applies to Mesh prims, not {prim.GetTypeName()!r}"
        )
    if plugin.register():
        schema_type = Usd.SchemaRegistry.GetTypeFromSchemaTypeName(SCHEMA_NAME)
        if schema_type:
            ok, why = prim.CanApplyAPI(schema_type)
            if not ok:
                raise UsdWriteError(f"{prim.GetPath()}: cannot apply {SCHEMA_NAME}: {why}")
    prim.AddAppliedSchema(SCHEMA_NAME)
    values = swpm_values(pm)
    for name, (sdf_type, value) in values.items():
        attr = prim.CreateAttribute(name, sdf_type, custom=False, variability=_UNIFORM)
        attr.Set(value)
    return set(values)


def _vec(a: np.ndarray, k: int) -> Any:
    a = np.ascontiguousarray(a, dtype=np.float32)
    return {1: Vt.FloatArray, 2: Vt.Vec2fArray, 3: Vt.Vec3fArray, 4: Vt.Vec4fArray}[k].FromNumpy(a)


def author_primvars(mesh: UsdGeom.Mesh, attributes: dict[str, np.ndarray]) -> None:
    """Per-vertex attributes (vertex interpolation): normal of 3 components -> normals, uv of 2 ->
    primvars:st, color of 3 or 4 -> displayColor (+ displayOpacity), any other -> primvars:<name> (so a
    colour of 1, 2 or 5+ components is primvars:color). Unsigned-integer colour components are normalised to
    [0, 1] (value / (2^bits - 1)) wherever they go; read scales them back."""
    T = Sdf.ValueTypeNames
    api = UsdGeom.PrimvarsAPI(mesh)
    vertex = UsdGeom.Tokens.vertex
    for name, a in attributes.items():
        a = np.asarray(a)
        a = a.reshape(a.shape[0], -1)
        k = a.shape[1]
        if name == "color" and a.dtype.kind == "u":  # display colour is in [0, 1]: u8 255 -> 1.0
            a = a.astype(np.float64) / float(np.iinfo(a.dtype).max)
        if name == "normal" and k == 3:
            mesh.CreateNormalsAttr().Set(_vec(a, 3))
            mesh.SetNormalsInterpolation(vertex)
        elif name == "uv" and k == 2:
            api.CreatePrimvar("st", T.TexCoord2fArray, vertex).Set(_vec(a, 2))
        elif name == "color" and k in (3, 4):
            api.CreatePrimvar("displayColor", T.Color3fArray, vertex).Set(_vec(a[:, :3], 3))
            if k == 4:
                api.CreatePrimvar("displayOpacity", T.FloatArray, vertex).Set(_vec(a[:, 3], 1))
        else:
            if not Sdf.Path.IsValidNamespacedIdentifier(name):
                raise UsdWriteError(f"attribute name {name!r} is not a valid USD primvar name")
            types = {1: T.FloatArray, 2: T.Float2Array, 3: T.Float3Array, 4: T.Float4Array}
            if k in types:
                api.CreatePrimvar(name, types[k], vertex).Set(_vec(a if k > 1 else a[:, 0], k))
            else:
                pv = api.CreatePrimvar(name, T.FloatArray, vertex, k)
                pv.Set(_vec(a.reshape(-1), 1))


def _topology(k_tris: np.ndarray) -> tuple[Any, Any]:
    tris = np.ascontiguousarray(k_tris, dtype=np.int32).reshape(-1)
    return Vt.IntArray.FromNumpy(tris), Vt.IntArray.FromNumpy(np.full(tris.shape[0] // 3, 3, np.int32))


def author_geometry(mesh: UsdGeom.Mesh, pm: ProgressiveMesh, discrete: Sequence[int] | None = None) -> None:
    """Points (LOD order), LOD-0 topology (or a LOD variant set), extent, primvars of ``pm`` on ``mesh``."""
    mesh.CreatePointsAttr().Set(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(pm.points, np.float32)))
    mesh.CreateSubdivisionSchemeAttr().Set(UsdGeom.Tokens.none)
    if pm.vertex_count:
        lo, hi = pm.points.min(axis=0), pm.points.max(axis=0)
        mesh.CreateExtentAttr().Set(Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))]))
    author_primvars(mesh, dict(pm.attributes))
    if not discrete:
        fvi, fvc = _topology(pm.triangles_at(0))
        mesh.CreateFaceVertexIndicesAttr().Set(fvi)
        mesh.CreateFaceVertexCountsAttr().Set(fvc)
        return
    # topology only inside the variants: a direct opinion would be stronger than every variant
    mesh.CreateFaceVertexIndicesAttr()
    mesh.CreateFaceVertexCountsAttr()
    vset = mesh.GetPrim().GetVariantSets().AddVariantSet(LOD_VARIANT_SET)
    for i, k in enumerate(discrete):
        vset.AddVariant(f"LOD{i}")
        vset.SetVariantSelection(f"LOD{i}")
        fvi, fvc = _topology(pm.triangles_at(int(k)))
        with vset.GetVariantEditContext():
            mesh.GetFaceVertexIndicesAttr().Set(fvi)
            mesh.GetFaceVertexCountsAttr().Set(fvc)
    vset.SetVariantSelection("LOD0")
    attr = mesh.GetPrim().CreateAttribute(
        "swpm:discreteLods", Sdf.ValueTypeNames.UIntArray, custom=False, variability=_UNIFORM
    )
    attr.Set(Vt.UIntArray.FromNumpy(np.asarray(discrete, np.uint32)))


def select_lods(pm: ProgressiveMesh, count: int, by: str = "triangles", ratio: float = 0.5) -> list[int]:
    """Progressive LOD indices of ``count`` discrete levels, LOD 0 first, strictly increasing.

    ``by="triangles"``: level i keeps about ``ratio**i`` of the LOD-0 triangles. ``by="error"``: errors
    spaced geometrically from the smallest non-zero LOD error to the largest. Duplicates are dropped, so
    fewer levels come back when the mesh has fewer distinct LODs.
    """
    if count < 1:
        raise UsdWriteError("the number of discrete LODs must be at least 1")
    if by == "triangles":
        # (lod_for_triangles refuses a negative or NaN target: name the ratio that made it)
        if not (isinstance(ratio, numbers.Real) and 0.0 <= ratio < math.inf):
            raise UsdWriteError(f"ratio must be a finite number >= 0 (triangles per LOD), not {ratio!r}")
        t0 = pm.triangle_count_at(0)
        picks = [pm.lod_for_triangles(int(math.floor(t0 * ratio**i))) for i in range(count)]
    elif by == "error":
        errs = pm.lod_errors[pm.lod_errors > 0]
        if errs.size == 0 or count == 1:
            picks = [0]
        else:
            targets = np.geomspace(float(errs[0]), float(errs[-1]), count - 1)
            picks = [0] + [pm.lod_for_error(float(e)) for e in targets]
    else:
        raise UsdWriteError(f"select LODs by 'triangles' or 'error', not {by!r}")
    return sorted(set(picks))


def _prim_name(path: Path, name: str | None) -> str:
    """The root prim's name: ``name``, else the file's stem up to its first dot, capitalised, as a USD
    identifier (a UTF-8 one as it is where usd-core takes it, as the pipeline's scene names its prims)."""
    raw = name or path.stem.split(".")[0] or "Asset"
    return valid_identifier(raw[0].upper() + raw[1:])


def _layer_args(path: Path, fmt: str | None) -> dict[str, str]:
    if fmt is None:
        return {}
    if fmt not in ("usda", "usdc"):
        raise UsdWriteError(f"format must be 'usda' or 'usdc', not {fmt!r}")
    return {"format": fmt}


class LayerReloadError(UsdWriteError):
    """A layer file was written (it is on disk, complete), but the layer of its name open in this process
    could not be reloaded: that layer object keeps its previous content. ``path``: the file; ``reason``:
    usd-core's message ("" when it gave none)."""

    code = "OUTPUT_UNWRITABLE"

    def __init__(self, path: str | os.PathLike[str], reason: str = "", message: str | None = None) -> None:
        self.path, self.reason = os.fspath(path), reason
        self.file = self.path
        why = f": {reason}" if reason else ""
        super().__init__(
            message
            or f"{self.path}: written, but the layer of that name open in this process could not be reloaded "
            f"(it keeps its previous content; open the file anew){why}"
        )


def reload_if_open(path: str | os.PathLike[str]) -> None:
    """A file just written at ``path``: a layer of that name already open in this process would keep its
    stale content, so it is reloaded. A reload usd-core fails is a :class:`LayerReloadError` that says the
    file was written (it was reported as "could not write")."""
    layer = Sdf.Layer.Find(str(path))
    if layer is None:
        return
    try:
        done = layer.Reload(force=True)
        why = "" if done else "usd-core did not reload it"
    except Tf.ErrorException as e:
        done, why = False, tf_message(e)
    if not done:
        raise LayerReloadError(path, why)


def _export(stage: Usd.Stage, path: Path, fmt: str | None) -> Path:
    args = _layer_args(path, fmt)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        done = stage.GetRootLayer().Export(str(path), args=args)
    except (OSError, Tf.ErrorException) as e:
        why = e.strerror or str(e) if isinstance(e, OSError) else tf_message(e)
        raise UsdWriteError(f"{path}: could not write: {why}") from e
    if not done:
        raise UsdWriteError(f"{path}: could not write")
    reload_if_open(path)
    return path


def _resolve_path(path: str | os.PathLike[str], fmt: str | None) -> Path:
    p = Path(path)
    if p.is_dir():  # (the suffix added to it would write a file beside the folder)
        raise UsdWriteError(f"{path}: is a folder; give the path of the layer to write")
    if p.suffix.lower() not in (".usd", ".usda", ".usdc"):
        p = p.with_name(p.name + "." + (fmt or "usdc"))
    if fmt is None and p.suffix.lower() == ".usd":
        fmt = "usdc"
    return p


def _positive(name: str, value: object) -> float:
    """``value`` as a float; a :class:`UsdWriteError` naming ``name`` unless it is a finite number above 0."""
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        number = math.nan
    if isinstance(value, bool) or not (math.isfinite(number) and number > 0):
        raise UsdWriteError(f"{name} must be a finite number above 0, not {value!r}")
    return number


def write(
    pm: ProgressiveMesh,
    path: str | os.PathLike[str],
    *,
    name: str | None = None,
    fmt: str | None = None,
    up_axis: str = "Y",
    meters_per_unit: float = 1.0,
    lods: int | None = None,
    lod_by: str = "triangles",
    identifier: str | None = None,
) -> Path:
    """Write ``pm`` as an asset layer: ``/<Name>`` (Xform, default prim) / ``mesh`` (Mesh + SwpmMeshAPI).

    ``.usdc`` by default (also for ``.usd``); ``.usda`` for a ``.usda`` path or ``fmt="usda"``. ``lods=n``
    adds the ``LOD`` variant set of :func:`select_lods` (``lod_by`` ``"triangles"`` or ``"error"``).
    ``up_axis`` ``"Y"`` or ``"Z"`` and ``meters_per_unit`` (above 0) are the stage's metadata; other values
    raise :class:`UsdWriteError`. ``identifier``: the root prim's ``assetInfo`` identifier, ``./<the file's
    name>`` by default (a caller that writes a temporary file and renames it gives the final name's).
    Returns the written path.
    """
    if str(up_axis).upper() not in ("Y", "Z"):  # (the only two USD defines)
        raise UsdWriteError(f"up_axis must be 'Y' or 'Z', not {up_axis!r}")
    scale = _positive("meters_per_unit", meters_per_unit)
    p = _resolve_path(path, fmt)
    if fmt is None and p.suffix.lower() == ".usd":
        fmt = "usdc"
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z if up_axis.upper() == "Z" else UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, scale)
    root = UsdGeom.Xform.Define(stage, Sdf.Path.absoluteRootPath.AppendChild(_prim_name(p, name)))
    model = Usd.ModelAPI(root.GetPrim())
    model.SetKind(Kind.Tokens.component)
    # assetInfo, as asset-management tools read it (usdview's Meta Data, UsdUtils' dependency tools): the
    # name, and the layer itself as the identifier, file-relative (anchored to this layer wherever it moves)
    model.SetAssetName(root.GetPrim().GetName())
    model.SetAssetIdentifier(Sdf.AssetPath("./" + p.name if identifier is None else identifier))
    stage.SetDefaultPrim(root.GetPrim())
    mesh = UsdGeom.Mesh.Define(stage, root.GetPath().AppendChild(MESH_NAME))
    discrete = select_lods(pm, lods, lod_by) if lods else None
    author_geometry(mesh, pm, discrete)
    author_swpm(mesh.GetPrim(), pm)
    return _export(stage, p, fmt)


def stage_metadata(source: str | os.PathLike[str]) -> dict[str, Any]:
    """:func:`write`'s ``up_axis`` and ``meters_per_unit`` for a mesh loaded from ``source``: a USD file's
    (its root layer's, USD's fallbacks where it authors none: the fallback up axis, Y unless the environment
    says otherwise, and centimetres), since the loader keeps the stage's coordinates; ``{}`` for any other
    file (OBJ, PLY, ... say nothing: the defaults). An up axis USD does not define is left out too."""
    from ..io import _USD_SUFFIXES  # (the loader's: the files it reads with usd-core)

    if Path(source).suffix.lower() not in _USD_SUFFIXES:
        return {}
    try:
        layer = Sdf.Layer.FindOrOpen(os.fspath(source))
    except Tf.ErrorException as e:
        raise UsdWriteError(f"{source}: USD could not open it: {tf_message(e)}") from e
    if layer is None:
        raise UsdWriteError(f"{source}: USD could not open it")
    info = layer.pseudoRoot
    up = str(info.GetInfo("upAxis")) if info.HasInfo("upAxis") else str(UsdGeom.GetFallbackUpAxis())
    scale = float(info.GetInfo("metersPerUnit")) if info.HasInfo("metersPerUnit") else 0.01
    out: dict[str, Any] = {}
    if up.upper() in ("Y", "Z"):
        out["up_axis"] = up.upper()
    if math.isfinite(scale) and scale > 0:
        out["meters_per_unit"] = scale
    return out


def _thresholds(errors: np.ndarray) -> np.ndarray:
    """Strictly increasing positive copy of ``errors`` (so heuristics get a valid threshold list)."""
    e = np.maximum.accumulate(np.maximum(np.asarray(errors, np.float64), 1e-12))
    for i in range(1, e.shape[0]):  # tiny list (one entry per discrete LOD)
        if e[i] <= e[i - 1]:
            e[i] = np.nextafter(np.float32(e[i - 1]), np.float32(np.inf))
    return e


def write_usdlod(
    asset_path: str | os.PathLike[str],
    path: str | os.PathLike[str],
    *,
    pixel_error: float = 1.0,
    viewport_px: int = 1080,
    fov_degrees: float = 60.0,
    fmt: str | None = None,
) -> Path:
    """Write a UsdLod layer over an asset written with ``lods``: one LOD item per discrete LOD.

    Layout: ``/<Name>LOD`` (Xform, default prim) / ``lod`` (LODRootAPI; items ``LOD0``.. each an instanceable
    internal reference to ``/<Name>LOD/sources/LOD<i>``, a class prim referencing the asset with that variant
    selected) and ``/<Name>LOD/heuristics`` (beside the root, not in it) holding an
    ``LODDistanceHeuristic`` and an ``LODScreenSizeHeuristic``. Item i switches to i+1 when the error of
    LOD i+1 projects to at most ``pixel_error`` pixels on a ``viewport_px`` tall view with a ``fov_degrees``
    vertical field of view: distance ``d = err * f / pixel_error`` with
    ``f = viewport_px / (2 tan(fov / 2))``, screen size ``s = 2 r f / (d * viewport_px)``
    (r: bounding radius).
    Needs usd-core >= 26.8 (UsdLod).
    """
    try:
        from pxr import UsdLod  # noqa: F401 - (the check: _author_usdlod uses it)
    except ImportError as e:  # pragma: no cover - older usd-core
        raise UsdWriteError("UsdLod needs usd-core >= 26.8; use the LOD variant set instead") from e
    pixel_error = _positive("pixel_error", pixel_error)
    if not (isinstance(viewport_px, numbers.Real) and math.isfinite(viewport_px) and viewport_px >= 1):
        raise UsdWriteError(f"viewport_px must be at least 1, not {viewport_px!r}")
    if not (isinstance(fov_degrees, numbers.Real) and 0 < fov_degrees < 180):
        raise UsdWriteError(f"fov_degrees must be in (0, 180), not {fov_degrees!r}")
    asset = Path(asset_path)
    if _resolve_path(path, fmt).resolve() == asset.resolve():
        raise UsdWriteError(f"{path}: the LOD layer must not be the asset it references")
    from .probe import checked

    with checked(asset) as probed:  # (a corrupt crate file that would crash this process: not opened here)
        if probed is not None:
            raise UsdWriteError(probed.message)
        try:
            src = Usd.Stage.Open(str(asset))
        except Tf.ErrorException as e:
            raise UsdWriteError(f"{asset}: USD could not open it: {tf_message(e)}") from e
    default = src.GetDefaultPrim()
    mesh_prim = default.GetChild(MESH_NAME) if default else None
    if not mesh_prim or not mesh_prim.GetAttribute("swpm:discreteLods").HasAuthoredValue():
        raise UsdWriteError(f"{asset}: no {MESH_NAME} prim with discrete LODs (write it with lods=n)")
    discrete = np.asarray(mesh_prim.GetAttribute("swpm:discreteLods").Get(), np.int64)
    errors = np.asarray(mesh_prim.GetAttribute("swpm:lodErrors").Get(), np.float64)[discrete]
    extent = np.asarray(UsdGeom.Mesh(mesh_prim).GetExtentAttr().Get(), np.float64).reshape(2, 3)

    p = _resolve_path(path, fmt).resolve()
    # a real (not anonymous) layer, so the relative reference to the asset resolves while authoring, under a
    # temporary name beside the output (the reference resolves the same), saved and renamed into place: a
    # failure leaves the previous file (and a layer of it open in this process) as it was (Sdf.Layer.CreateNew
    # writes an empty layer at once)
    tmp = p.with_name(f".{p.stem}.{secrets.token_hex(4)}.tmp{p.suffix}")
    try:
        fill_layer_replacing(
            p,
            tmp,
            lambda layer: _author_usdlod(
                layer, src, default, asset, p, discrete, errors, extent, pixel_error, viewport_px, fov_degrees
            ),
            _layer_args(p, fmt),
        )
    except (OSError, Tf.ErrorException) as e:  # (a LayerReloadError, written, is neither: raised as it is)
        why = e.strerror or str(e) if isinstance(e, OSError) else tf_message(e)
        raise UsdWriteError(f"{p}: could not write: {why.replace(str(tmp), str(p))}") from e
    return p


def _author_usdlod(
    layer: Sdf.Layer,
    src: Usd.Stage,
    default: Usd.Prim,
    asset: Path,
    p: Path,
    discrete: np.ndarray,
    errors: np.ndarray,
    extent: np.ndarray,
    pixel_error: float,
    viewport_px: float,
    fov_degrees: float,
) -> None:
    """Fill the new, empty ``layer`` (to be renamed to ``p``) with :func:`write_usdlod`'s prims."""
    from pxr import UsdLod

    center = extent.mean(axis=0)
    radius = 0.5 * float(np.linalg.norm(extent[1] - extent[0]))
    stage = Usd.Stage.Open(layer)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.GetStageUpAxis(src))
    UsdGeom.SetStageMetersPerUnit(stage, UsdGeom.GetStageMetersPerUnit(src))
    top = UsdGeom.Xform.Define(stage, f"/{default.GetName()}LOD")
    stage.SetDefaultPrim(top.GetPrim())
    Usd.ModelAPI(top.GetPrim()).SetKind(Kind.Tokens.assembly)
    lod_root = UsdGeom.Xform.Define(stage, top.GetPath().AppendChild("lod"))
    # a group model between the assembly and the items (component models: models only under group models)
    Usd.ModelAPI(lod_root.GetPrim()).SetKind(Kind.Tokens.group)
    rel_asset = os.path.relpath(asset.resolve(), p.resolve().parent).replace(os.sep, "/")
    # file-relative, as scene.usda's references are: a bare "spot.usda" is a search path to USD (the default
    # resolver anchors it to the layer first, a studio's resolver may look it up in its search paths only)
    rel_asset = rel_asset if rel_asset.startswith("../") else "./" + rel_asset
    # USD ignores opinions authored under an instanceable prim (an `over "mesh"` with the variant selection
    # beneath the item left every item drawing LOD0): each selection is made on a class prim beside the LOD
    # root, `sources/LOD<i>` (abstract: neither drawn nor traversed), that references the asset, and each item
    # is an instanceable internal reference to its source, so the selection is part of its prototype (four
    # prototypes, shared by every reference to this layer)
    sources = stage.CreateClassPrim(top.GetPath().AppendChild(LOD_SOURCES))
    for i in range(discrete.shape[0]):
        source = stage.CreateClassPrim(sources.GetPath().AppendChild(f"LOD{i}"))
        source.GetReferences().AddReference(rel_asset)
        over = Sdf.CreatePrimInLayer(layer, source.GetPath().AppendChild(MESH_NAME))
        over.specifier = Sdf.SpecifierOver
        over.variantSelections[LOD_VARIANT_SET] = f"LOD{i}"
        item = UsdGeom.Xform.Define(stage, lod_root.GetPath().AppendChild(f"LOD{i}")).GetPrim()
        item.GetReferences().AddInternalReference(source.GetPath())
        item.SetInstanceable(True)
    heur = UsdGeom.Scope.Define(stage, top.GetPath().AppendChild("heuristics"))
    # the focal length in pixels, f = viewport_px / (2 tan(fov / 2)), as the one projection of the LOD queries
    # gives it: the pixels one unit covers at distance 1 (the same float, bit for bit, as f computed inline)
    focal = screen_space_error(1.0, 1.0, math.radians(fov_degrees), viewport_px)
    dist = _thresholds(errors[1:] * focal / pixel_error)
    screen = 2.0 * radius * focal / (dist * viewport_px)
    dh = UsdLod.DistanceHeuristic.Define(stage, heur.GetPath().AppendChild("distance"))
    dh.CreateLodDomainAttr().Set(UsdLod.Tokens.imaging)
    dh.CreateThresholdsAttr().Set(Vt.FloatArray.FromNumpy(dist.astype(np.float32)))
    dh.CreateCenterAttr().Set(Gf.Vec3f(*map(float, center)))
    sh = UsdLod.ScreenSizeHeuristic.Define(stage, heur.GetPath().AppendChild("screenSize"))
    sh.CreateLodDomainAttr().Set(UsdLod.Tokens.imaging)
    sh.CreateThresholdsAttr().Set(Vt.FloatArray.FromNumpy(screen.astype(np.float32)))
    sh.CreateExtentAttr().Set(Vt.Vec3fArray.FromNumpy(extent.astype(np.float32)))
    api = UsdLod.RootAPI.Apply(lod_root.GetPrim())
    api.CreateLodDefaultIndexAttr().Set(0)
    api.CreateLodHeuristicsRel().SetTargets([dh.GetPath(), sh.GetPath()])
