"""Read progressive meshes back from USD prims, through any composition (references, payloads, instances).

:func:`read` rebuilds exactly the :class:`~swpm_usd.encode.base.ProgressiveMesh` that was written: the
buffers are the stored arrays viewed as numpy (zero-copy where the dtype matches, no Python loops), so they
equal ``pm.buffers()`` / the ``.swpm`` file byte for byte. Works without the schema plugin too: every value
the reader needs is authored explicitly.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from pxr import Sdf, Tf, Usd, UsdGeom

from ..encode.base import ProgressiveMesh, from_buffers, with_attributes
from ..errors import SwpmError, first_few, tf_message
from ..format.meta import parse_meta_json
from .arrays import ATTRIBUTE_DTYPES, BUFFER_DTYPES, dtype_problem, from_vt
from .schema import COLLAPSE_PREFIX, FORMAT_VERSION, PROPERTY_TYPES, SCHEMA_NAME, attr_name

_PROXIES = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)


class UsdReadError(SwpmError):
    """A prim does not hold a readable progressive mesh."""

    code = "INPUT_MALFORMED"
    format = "usd"


def _snake(name: str) -> str:
    return "".join("_" + c.lower() if c.isupper() else c for c in name)


def is_encoded(prim: Usd.Prim) -> bool:
    """True for a prim that has SwpmMeshAPI applied (whether or not the plugin is registered)."""
    if SCHEMA_NAME in prim.GetAppliedSchemas():
        return True
    ops = prim.GetMetadata("apiSchemas")
    return bool(ops) and SCHEMA_NAME in ops.GetAddedOrExplicitItems()


def find_encoded(root: Usd.Stage | Usd.Prim) -> list[Usd.Prim]:
    """Every encoded prim at or under ``root`` (a stage: the whole stage), instance proxies included."""
    start = root.GetPseudoRoot() if isinstance(root, Usd.Stage) else root
    return [p for p in Usd.PrimRange(start, _PROXIES) if p.IsA(UsdGeom.Mesh) and is_encoded(p)]


def _encoded_prim(prim: Usd.Prim) -> Usd.Prim:
    if not prim or not prim.IsValid():
        # a prim of a stage nobody holds any more is invalid too: Usd.Stage.Open(f).GetDefaultPrim(); it
        # keeps its path, where the null prim of GetPrimAtPath(a path the stage lacks) has none (both were
        # told to keep the stage in a variable)
        try:
            path = str(prim.GetPath()) if prim is not None else ""
        except Exception:  # noqa: BLE001 - (an object that is no Usd.Prim: said as the null prim)
            path = ""
        if not path:
            raise UsdReadError(
                "invalid prim: a null prim, no prim at the path asked (GetPrimAtPath of a path the stage "
                "does not hold, or GetDefaultPrim of a stage without one)"
            )
        raise UsdReadError(
            f"invalid prim {path}: not a prim of an open stage (keep the Usd.Stage in a variable while "
            "reading)"
        )
    if is_encoded(prim):
        return prim
    found = find_encoded(prim)
    if len(found) != 1:
        what = "no" if not found else f"{len(found)}"
        raise UsdReadError(
            f"{_where(prim)}: {what} SwpmMeshAPI Mesh prims at or under it (need exactly one)"
            + ("" if found else _unloaded(prim))
        )
    return found[0]


def _unloaded(prim: Usd.Prim) -> str:
    """``"; payloads at or under it not loaded (1): /World/a (stage.Load(path) loads one)"``: what hides an
    encoded mesh from a stage opened with ``Usd.Stage.LoadNone`` (or unloaded since), or ``""``."""
    every = Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)
    paths = [
        str(p.GetPath()) for p in Usd.PrimRange(prim, every) if p.HasAuthoredPayloads() and not p.IsLoaded()
    ]
    if not paths:
        return ""
    listed = first_few(paths)
    return f"; payloads at or under it not loaded ({len(paths)}): {listed} (stage.Load(path) loads one)"


def stored_value(attr: Usd.Attribute) -> tuple[Any, str]:
    """``(value, "")`` for an attribute with a value authored at the default time (every ``swpm:`` attribute
    is uniform), else ``(None, why)``: ``""`` (not authored), ``" (it is blocked)"`` or ``" (it has only time
    samples)"``. The schema's fallback is no stored value: with the plugin registered ``attr.Get()`` gives
    it (``"vanilla"`` for a prim without ``swpm:encoding``, ``[]`` without ``swpm:indices``), where a tool
    without the plugin reads None, so a prim that lacks one read and validated as another."""
    if not attr:
        return None, ""
    info = attr.GetResolveInfo(Usd.TimeCode.Default())
    if info.GetSource() == Usd.ResolveInfoSourceDefault:
        return attr.Get(), ""
    if info.ValueIsBlocked():
        return None, " (it is blocked)"
    return None, " (it has only time samples)" if attr.GetNumTimeSamples() else ""


def authored_type(attr: Usd.Attribute) -> str:
    """The type name ``attr`` is authored with (its strongest spec's): with the plugin registered
    ``attr.GetTypeName()`` is the schema's whatever the layer holds."""
    stack = attr.GetPropertyStack()
    return str(stack[0].typeName) if stack else str(attr.GetTypeName())


def _get(prim: Usd.Prim, name: str, required: bool = True) -> Any:
    attr = prim.GetAttribute(name)
    try:
        value, why = stored_value(attr)
    except Tf.ErrorException as e:  # (corrupt .usdc data: a value that does not decompress or unpack)
        raise UsdReadError(f"{_where(prim)}: usd-core cannot read {name}: {tf_message(e)}") from e
    if value is None:
        if required:
            raise UsdReadError(f"{_where(prim)}: attribute {name} is missing{why}{_overridden(prim)}")
        return None
    expected = PROPERTY_TYPES.get(name)
    if expected is not None and authored_type(attr) != expected:
        # (cast as it came, an int[] index -1 became 4294967295 and a float[] 1.5 became 1: validate's
        # SWPM_USD_TYPE, which read passed)
        raise UsdReadError(
            f"{_where(prim)}: {name} is authored as {authored_type(attr)}, expected {expected}"
            f"{_overridden(prim)}"
        )
    return value


def _check_version(prim: Usd.Prim) -> None:
    """The prim's ``swpm:formatVersion`` is the layout this reader reads: another version may store its
    buffers otherwise (validate's ``SWPM_USD_VERSION``, which read passed, reading a version 2 as 1)."""
    version = _get(prim, "swpm:formatVersion")
    if int(version) != FORMAT_VERSION:
        raise UsdReadError(
            f"{_where(prim)}: swpm:formatVersion {version} is not supported (this reader reads "
            f"{FORMAT_VERSION}){_overridden(prim)}"
        )


def read_buffers(prim: Usd.Prim) -> dict[str, np.ndarray]:
    """The encoding's buffers stored on ``prim`` (an encoded Mesh, or a prim with one below it)."""
    prim = _encoded_prim(prim)
    _check_version(prim)
    return _stored_buffers(prim)


def _stored_buffers(prim: Usd.Prim) -> dict[str, np.ndarray]:
    """:func:`read_buffers` of an encoded prim whose version is checked (:func:`read` has found and checked
    it)."""
    names = list(_get(prim, "swpm:bufferNames"))
    dtypes = list(_get(prim, "swpm:bufferDtypes"))
    problem = dtype_problem("swpm:bufferDtypes", dtypes, BUFFER_DTYPES)
    if problem is not None:
        raise UsdReadError(f"{_where(prim)}: {problem}")
    columns = np.asarray(_get(prim, "swpm:bufferColumns"))
    if not len(names) == len(dtypes) == columns.shape[0]:
        raise UsdReadError(
            f"{_where(prim)}: swpm:bufferNames / bufferDtypes / bufferColumns differ in length"
        )
    fields = list(_get(prim, "swpm:collapseRecordFields", required=False) or [])
    table = None
    if fields:
        table = from_vt(_get(prim, "swpm:collapseRecords"), np.uint32)
        if table.shape[0] % len(fields):
            raise UsdReadError(
                f"{_where(prim)}: swpm:collapseRecords has {table.shape[0]} entries, "
                f"not a multiple of {len(fields)} fields"
            )
        table = table.reshape(-1, len(fields))
    column_of = {COLLAPSE_PREFIX + _snake(f): i for i, f in enumerate(fields)}
    out: dict[str, np.ndarray] = {}
    for name, dtype, cols in zip(names, dtypes, columns.tolist(), strict=True):
        if name in column_of and table is not None:
            out[name] = np.ascontiguousarray(table[:, column_of[name]]).astype(dtype, copy=False)
        else:
            value = _get(prim, attr_name(name))
            if cols and len(value) % int(cols):  # (named here: numpy's reshape error named neither)
                raise UsdReadError(
                    f"{_where(prim)}: {attr_name(name)} has {len(value)} entries, not a multiple of its "
                    f"row width {int(cols)} (swpm:bufferColumns){_overridden(prim)}"
                )
            out[name] = from_vt(value, dtype, int(cols))
    return out


def _restore(name: str, a: np.ndarray, dtype: str | None) -> np.ndarray:
    """The float32 primvar values ``a`` of attribute ``name`` back in the attribute's ``dtype`` (from
    swpm:attributeDtypes; None: float32): unsigned-integer colours were normalised to [0, 1] when written."""
    dt = np.dtype(dtype or np.float32)
    if dt == a.dtype:
        return a
    if dt.kind == "b":  # (written as 0 / 1)
        return a != 0
    if dt.kind in "ui":
        info = np.iinfo(dt)
        v = np.rint(a.astype(np.float64) * (float(info.max) if name == "color" and dt.kind == "u" else 1.0))
        # float(info.max) of a 64-bit type is 2^63 / 2^64, which does not fit it: values from there (the
        # type's maximum written as float32) are the maximum, not cast (int64 2^63 - 1 came back as -2^63)
        top = v >= float(info.max)
        out = np.clip(np.where(top, 0.0, v), info.min, info.max).astype(dt)
        out[top] = info.max
        return out
    return a.astype(dt)


def _attributes(prim: Usd.Prim, names: list[str], dtypes: list[str] | None = None) -> dict[str, np.ndarray]:
    """The per-vertex attributes ``names`` from their primvars, each cast back to its ``dtypes`` entry."""
    if dtypes is not None:
        problem = dtype_problem("swpm:attributeDtypes", dtypes, ATTRIBUTE_DTYPES)
        if problem is not None:
            raise UsdReadError(f"{_where(prim)}: {problem}")
    out = _float_attributes(prim, names)
    if dtypes is None:
        return out
    if len(dtypes) != len(names):
        raise UsdReadError(f"{_where(prim)}: swpm:attributeNames and attributeDtypes differ in length")
    return {n: _restore(n, out[n], str(d)) for n, d in zip(names, dtypes, strict=True)}


def _flattened(prim: Usd.Prim, pv: UsdGeom.Primvar) -> Any:
    """``pv``'s values, an indexed primvar's expanded by its indices (None without a value); indices out of
    range are a :class:`UsdReadError` (usd-core's ComputeFlattened gives None, as for no value at all)."""
    value = pv.ComputeFlattened()
    if value is None and pv.IsIndexed() and pv.Get() is not None:
        n = len(pv.Get())
        raise UsdReadError(
            f"{_where(prim)}: primvar {pv.GetPrimvarName()!r} has indices out of range for its {n} values"
        )
    return value


def _float_attributes(prim: Usd.Prim, names: list[str]) -> dict[str, np.ndarray]:
    """As the writer stores them: normal (3 components) from normals, uv (2) from primvars:st, color (3, 4)
    from displayColor (+ displayOpacity); any other shape or name from primvars:<name>."""
    mesh = UsdGeom.Mesh(prim)
    api = UsdGeom.PrimvarsAPI(prim)
    out = {}
    for name in names:
        own = name in ("normal", "uv", "color") and api.GetPrimvar(name).HasAuthoredValue()
        # primvars flattened: an indexed one (as a DCC may re-save it) holds distinct values + indices
        if name == "normal" and not own:
            normals = api.GetPrimvar("normals")
            value = _flattened(prim, normals) if normals.HasAuthoredValue() else mesh.GetNormalsAttr().Get()
        elif name == "uv" and not own:
            value = _flattened(prim, api.GetPrimvar("st"))
        elif name == "color" and not own:
            value = _flattened(prim, api.GetPrimvar("displayColor"))
            opacity = api.GetPrimvar("displayOpacity")
            if value is not None and opacity and opacity.HasAuthoredValue():
                rgb = np.asarray(value, np.float32).reshape(-1, 3)
                alpha = np.asarray(_flattened(prim, opacity), np.float32).reshape(-1, 1)
                out[name] = np.concatenate([rgb, alpha], axis=1)
                continue
        else:
            pv = api.GetPrimvar(name)
            value = _flattened(prim, pv) if pv else None
            if value is not None:
                a = np.asarray(value, np.float32)
                out[name] = a.reshape(a.shape[0] // pv.GetElementSize(), -1) if a.ndim == 1 else a
                continue
        if value is None:
            raise UsdReadError(f"{_where(prim)}: attribute {name!r} has no stored primvar")
        a = np.asarray(value, np.float32)
        out[name] = a.reshape(a.shape[0], -1)
    return out


def read(prim: Usd.Prim, check: bool = True) -> ProgressiveMesh:
    """The :class:`ProgressiveMesh` stored on ``prim`` (an encoded Mesh, an instance proxy of one, or a
    prim with exactly one below it, e.g. an asset's default prim).

    ``check`` (default): the buffers must pass every check a ``.swpm`` reader makes (``spec/format.md``),
    else :class:`UsdReadError` names the prim and the first problem, so an edited or corrupt stage cannot
    reach the runtime's unchecked kernels (a collapse record pointing outside the index buffer would
    corrupt memory). It costs about 2-3x the read itself (bunny: 7-26 ms); ``check=False`` skips it for
    stages this package just wrote."""
    prim = _encoded_prim(prim)
    _check_version(prim)
    encoding = str(_get(prim, "swpm:encoding"))
    points = np.asarray(_get(prim, "points"), np.float32).reshape(-1, 3)
    try:
        params = parse_meta_json(_get(prim, "swpm:params", required=False) or "{}")
        if not isinstance(params, dict):
            raise ValueError(f"a JSON {type(params).__name__}, not an object")
    except (ValueError, RecursionError) as e:
        # (it was "the stored arrays do not form a progressive mesh: cannot convert dictionary update
        # sequence element #0 to a sequence" for params [1, 2], naming no attribute)
        raise UsdReadError(
            f"{_where(prim)}: swpm:params is not a JSON object a .swpm META may hold: {e}{_overridden(prim)}"
        ) from e
    try:
        pm = from_buffers(
            encoding,
            points,
            _attributes(
                prim,
                list(_get(prim, "swpm:attributeNames", required=False) or []),
                _get(prim, "swpm:attributeDtypes", required=False),
            ),
            from_vt(_get(prim, "swpm:vertexCounts"), np.int64),
            from_vt(_get(prim, "swpm:triangleCounts"), np.int64),
            from_vt(_get(prim, "swpm:lodErrors"), np.float32),
            _stored_buffers(prim),
            params,
        )
    except UsdReadError:
        raise
    except Tf.ErrorException as e:  # (a primvar's value usd-core cannot read: corrupt .usdc data)
        raise UsdReadError(f"{_where(prim)}: usd-core cannot read a value: {tf_message(e)}") from e
    except (SwpmError, ValueError, TypeError, IndexError, KeyError, RecursionError) as e:
        raise UsdReadError(
            f"{_where(prim)}: the stored arrays do not form a progressive mesh: {e}{_overridden(prim)}"
        ) from e
    if check:
        _check_buffers(prim, pm)
    return pm


def read_file(path: str | os.PathLike[str], prim: str | None = None, check: bool = True) -> ProgressiveMesh:
    """The :class:`ProgressiveMesh` stored in the USD stage at ``path`` (what :func:`swpm_usd.load` gives for
    a ``.usd`` ``.usda`` ``.usdc`` ``.usdz`` path): the encoded prim at ``prim`` (a path; a prim with exactly
    one encoded prim below it will do, as :func:`read` takes), else the stage's only encoded prim.
    :class:`UsdReadError` names the file and what is wrong: missing (code ``INPUT_NOT_FOUND``), not a
    regular file, not a stage usd-core opens, no encoded prim, several (listed: pass ``prim``), or a prim
    whose buffers fail :func:`read`'s checks. A stage that opens a crate file is opened first in a probe
    process (:mod:`swpm_usd.usd.probe`): one usd-core crashes on, hangs on or fails to read there is a
    :class:`UsdReadError` with what the probe found, never opened in this process."""
    from ..fileio import missing_file_problem
    from .probe import checked
    from .validate import _open

    name = os.fspath(path)
    if not os.path.isfile(name):  # (a FIFO is never opened: its open would wait for a writer)
        missing = not os.path.exists(name)
        err = UsdReadError(f"{name}: " + (missing_file_problem(name) if missing else "not a regular file"))
        err.code = "INPUT_NOT_FOUND" if missing else "INPUT_UNREADABLE"
        raise err
    # a crate file is untrusted input usd-core does not always survive (spec/usd.md): opened first in a probe
    # process, as validate and the loader do, and here only if that ends cleanly (swpm_usd.load of a
    # corrupt .usdc died by SIGSEGV, or raised pxr's Tf.ErrorException for a value that does not decompress)
    with checked(name) as probed:
        if probed is not None:
            raise UsdReadError(probed.message)
        stage, why = _open(name)
    if stage is None:
        raise UsdReadError(why)
    if prim is not None:
        found = stage.GetPrimAtPath(prim) if Sdf.Path.IsValidPathString(prim) else Usd.Prim()
        if not found:
            raise UsdReadError(f"{name}: no prim at {prim!r}")
        return read(found, check=check)
    encoded = find_encoded(stage)
    if len(encoded) != 1:
        listed = first_few([str(p.GetPath()) for p in encoded])
        raise UsdReadError(
            f"{name}: no prim has {SCHEMA_NAME} applied"
            if not encoded
            # (named with its function: swpm_usd.load, which comes here, takes no prim=)
            else f"{name}: {len(encoded)} prims have {SCHEMA_NAME} applied ({listed}): "
            f"swpm_usd.usd.read_file({name!r}, prim=...) reads one"
        )
    return read(encoded[0], check=check)


def _where(prim: Usd.Prim) -> str:
    """The stage's root layer and the prim's path, for a message."""
    return f"{prim.GetStage().GetRootLayer().identifier}: {prim.GetPath()}"


def _overridden(prim: Usd.Prim) -> str:
    """Where the encoded ``prim``'s values may have been broken: its ``swpm:`` attributes and ``points`` whose
    strongest opinion is in another layer than its ``swpm:bufferNames`` (the writer authors them together,
    so on a composed stage these are the overrides), as ``"; overridden over a.usdc: swpm:indexPool in
    over.usda"``, or ``""`` when there is none."""
    ref = prim.GetAttribute("swpm:bufferNames")
    stack = ref.GetPropertyStack() if ref else []
    if not stack:
        return ""
    home = stack[0].layer
    out = []
    for attr in prim.GetAttributes():
        name = attr.GetName()
        if not (name.startswith("swpm:") or name in ("points", "faceVertexIndices", "faceVertexCounts")):
            continue
        specs = attr.GetPropertyStack()
        if specs and specs[0].layer != home:
            out.append(f"{name} in {specs[0].layer.identifier}")
    if not out:
        return ""
    return f"; overridden over {home.identifier}: {', '.join(out)}"


def _check_buffers(prim: Usd.Prim, pm: ProgressiveMesh) -> None:
    """The ``.swpm`` reader's checks on ``pm`` (its buffers written as a file and validated)."""
    from ..format.reader import validate_bytes
    from ..format.writer import encode_bytes

    where = _where(prim)
    try:
        errors = validate_bytes(encode_bytes(_storable(pm))).errors
    except (SwpmError, ValueError, TypeError, IndexError, OverflowError) as e:
        raise UsdReadError(
            f"{where}: the stored arrays do not form a valid {pm.encoding} mesh: {e}{_overridden(prim)}"
        ) from e
    if errors:
        first = errors[0]
        raise UsdReadError(
            f"{where}: the stored arrays fail the format's checks ({len(errors)} problem(s)); "
            f"first: {first.code}: {first.message}{_overridden(prim)}"
        )


def _storable(pm: ProgressiveMesh) -> ProgressiveMesh:
    """``pm``, or a copy whose attributes of a type a ``.swpm`` file cannot hold (bool, int64, uint64: a USD
    stage can) are float64 of the same shape, for the format's checks (which look at the buffers, and at
    attributes only for their shape)."""
    from ..format.layout import ELEM_CODES

    attrs = dict(pm.attributes)
    odd = [n for n, a in attrs.items() if np.dtype(a.dtype).newbyteorder("<").str not in ELEM_CODES]
    if not odd:
        return pm
    attrs.update({n: np.asarray(attrs[n], np.float64) for n in odd})
    return with_attributes(pm, attrs)
