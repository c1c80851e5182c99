"""One SwpmMeshAPI prim checked against the format's invariants (:func:`validate_prim`), each problem a
:class:`Finding` with a stable code (:data:`CODES`, listed in spec/usd.md).

The checks: a Mesh, every required attribute authored with the schema's type, a known encoding and format
version, a consistent LOD table, strides and parallel arrays, sliding windows inside the index pool, vertex
indices below the vertex count, the index width the indices need, and the buffers rebuilding a progressive
mesh. Separate from :mod:`.validate`, which registers them with UsdValidation, checks one instance
prototype once, and runs them with usd-core's own validators on a stage.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from pxr import Usd, UsdGeom

from ..format.layout import INDEX_ARRAYS, draw_index_width
from ..format.meta import parse_meta_json
from .arrays import ATTRIBUTE_DTYPES, BUFFER_DTYPES, dtype_problem
from .reader import _snake, authored_type, is_encoded, stored_value
from .schema import COLLAPSE_PREFIX, ENCODING_TOKENS, FORMAT_VERSION, PROPERTY_TYPES, attr_name

ERROR, WARNING = "error", "warning"

#: stable finding codes of our validator -> what they mean
CODES: dict[str, str] = {
    "SWPM_USD_NOT_MESH": "SwpmMeshAPI is applied to a prim that is not a Mesh.",
    "SWPM_USD_MISSING": "a required swpm: attribute (or points) has no value.",
    "SWPM_USD_TYPE": "an attribute's type differs from the schema (or a buffer/attribute dtype is not one "
    "the writer stores: buffers integers, attributes numbers).",
    "SWPM_USD_ENCODING": "swpm:encoding names no known encoding.",
    "SWPM_USD_VERSION": "swpm:formatVersion is not supported by this reader.",
    "SWPM_USD_LOD_TABLE": "vertexCounts / triangleCounts / lodErrors disagree in length, order or range.",
    "SWPM_USD_STRIDE": "an array's length is not a multiple of its row width or parallel arrays differ.",
    "SWPM_USD_WINDOW_RANGE": "a sliding window lies (partly) outside swpm:indexPool.",
    "SWPM_USD_INDEX_RANGE": "a vertex index is not below the vertex count.",
    "SWPM_USD_TOPOLOGY": "faceVertexIndices / Counts are not a triangle list of one of the LODs.",
    "SWPM_USD_PARAMS": "swpm:params is not a JSON object a .swpm META may hold (spec/format.md 3.1).",
    "SWPM_USD_REBUILD": "the stored buffers do not rebuild a progressive mesh.",
    "SWPM_USD_INDEX_WIDTH": "swpm:indexWidth is not the width the prim's indices need (2 below 65,536 "
    "vertices, every vertex id then below u16's all ones 0xFFFF, while a strip pool's restart index fits in "
    "16 bits, 0xFFFFFFFF counting as u16's 0xFFFF, else 4; 4 is also accepted with a restart index "
    "0xFFFFFFFF: its values drawn as stored, u32).",
    "SWPM_USD_OPEN": "the file is not a USD layer usd-core can open (empty, truncated or not USD at all), "
    "or it or a layer its stage opens is not a regular file (a FIFO, a folder, a device: never opened).",
    "SWPM_USD_READ": "usd-core opened the layer but cannot read a value in it (corrupt .usdc data).",
    "SWPM_USD_LAYER_MISSING": "a sublayer, reference or payload the stage names does not open (no such file, "
    "or not a USD layer): the prims it brings are missing from the stage.",
    "SWPM_USD_CRASH": "usd-core crashed (died by a signal) or hung opening or reading the .usdc file in a "
    "probe process (corrupt data); it is not opened in the validating process.",
    "SWPM_USD_PROBE": "the probe process that opens a crate file first failed itself, twice (not usd-core on "
    "the file); the file is not opened in the validating process.",
}


# buffers whose values are vertex ids: the index lists (the file's idx arrays) and two record columns
_VERTEX_BUFFERS = (*INDEX_ARRAYS, "collapse_kept", "collapse_binned")


_REQUIRED = (
    "swpm:formatVersion",
    "swpm:encoding",
    "swpm:vertexCounts",
    "swpm:triangleCounts",
    "swpm:lodErrors",
    "swpm:bufferNames",
    "swpm:bufferDtypes",
    "swpm:bufferColumns",
)


@dataclass(frozen=True)
class Finding:
    """One problem: stable ``code``, ``severity`` ("error" / "warning"), ``prim`` path, ``message``."""

    code: str
    severity: str
    prim: str
    message: str

    def to_dict(self) -> dict[str, str]:
        return asdict(self)


class _Check:
    def __init__(self, prim: Usd.Prim) -> None:
        self.prim = prim
        self.where = str(prim.GetPath())
        self.found: list[Finding] = []

    def add(self, code: str, message: str, severity: str = ERROR, attrs: tuple[str, ...] = ()) -> None:
        """A finding; ``attrs``: the attributes it is about, each named with the layer of its strongest
        opinion (on a composed stage, the layer to fix: the sublayer whose override broke the buffers, not
        the asset it overrides)."""
        self.found.append(Finding(code, severity, self.where, message + self.authored(attrs)))

    def authored(self, attrs: tuple[str, ...]) -> str:
        """`` (swpm:indexPool in over.usda; ...)``: the layer of each attribute's strongest opinion."""
        parts = []
        for name in attrs:
            attr = self.prim.GetAttribute(name)
            stack = attr.GetPropertyStack() if attr else []
            if stack:
                parts.append(f"{name} in {stack[0].layer.identifier}")
        return f" ({'; '.join(parts)})" if parts else ""

    def get(self, name: str, required: bool = True) -> Any:
        """The value authored for ``name``, never the schema's fallback (``stored_value``: an optional
        attribute left out is None, not a fallback checked as if authored, ``swpm:indexWidth`` 4)."""
        attr = self.prim.GetAttribute(name)
        value, why = stored_value(attr)
        if value is None:
            if required:
                self.add("SWPM_USD_MISSING", f"{name} has no value{why}", attrs=(name,))
            return None
        expected = PROPERTY_TYPES.get(name)
        if expected is not None:
            authored = authored_type(attr)
            if authored != expected:
                self.add(
                    "SWPM_USD_TYPE", f"{name} is authored as {authored}, expected {expected}", attrs=(name,)
                )
                return None
        return value


def _stored_in(buffer: str, fields: list[str]) -> str:
    """The attribute that stores ``buffer``: swpm:collapseRecords for a column of it (``fields``)."""
    return "swpm:collapseRecords" if buffer in fields else attr_name(buffer)


def _array(value: Any, dtype: Any = np.int64) -> np.ndarray:
    return np.asarray(value).astype(dtype, copy=False).reshape(-1)


def _check_index_width(c: _Check, V: int, params: dict[str, Any]) -> None:
    """An authored ``swpm:indexWidth`` is the one the writer derives (spec/usd.md): a runtime uploads the
    indices at that width, so 3, or 2 over a vertex id 0xFFFF or past, was a stage validate passed."""
    width = c.get("swpm:indexWidth", required=False)
    if width is None:
        return
    ri = params.get("restart_index") if params.get("primitive") != "list" else None
    ri = ri if isinstance(ri, int) and not isinstance(ri, bool) else None
    need = draw_index_width(V, ri)
    # (4 beside 0xFFFFFFFF is a runtime drawing the stored u32 values as they are: not wrong, only wider)
    if int(width) != need and not (int(width) == 4 and ri == 0xFFFFFFFF):
        why = f"vertex ids up to {max(V - 1, 0)}" + ("" if ri is None else f", restart index {ri}")
        c.add(
            "SWPM_USD_INDEX_WIDTH",
            f"swpm:indexWidth is {int(width)}, the indices need {need} ({why})",
            attrs=("swpm:indexWidth", "points"),
        )


def validate_prim(prim: Usd.Prim) -> list[Finding]:
    """Our invariants on one prim (no findings for a prim without SwpmMeshAPI)."""
    if not is_encoded(prim):
        return []
    c = _Check(prim)
    if not prim.IsA(UsdGeom.Mesh):
        c.add("SWPM_USD_NOT_MESH", f"SwpmMeshAPI on a {prim.GetTypeName() or 'typeless'} prim")
        return c.found
    values = {n: c.get(n) for n in _REQUIRED}
    points = c.get("points")
    if points is None or any(v is None for v in values.values()):
        return c.found
    from ..encode.base import ENCODINGS

    encoding = str(values["swpm:encoding"])
    if encoding not in ENCODING_TOKENS or encoding not in ENCODINGS:
        c.add(
            "SWPM_USD_ENCODING",
            f"swpm:encoding {encoding!r} is not one of {sorted(ENCODINGS)}",
            attrs=("swpm:encoding",),
        )
    if int(values["swpm:formatVersion"]) != FORMAT_VERSION:
        c.add(
            "SWPM_USD_VERSION",
            f"swpm:formatVersion {values['swpm:formatVersion']} (supported: {FORMAT_VERSION})",
        )
    params = c.get("swpm:params", required=False)
    try:
        # the rules of a .swpm file's META (spec/format.md 3.1), so the stage and its .swpm agree
        params = parse_meta_json(params) if params is not None else {}
        if not isinstance(params, dict):
            raise ValueError("not an object")
    except (ValueError, RecursionError) as e:
        c.add("SWPM_USD_PARAMS", f"swpm:params: {e}")
        params = {}

    attr_dtypes = c.get("swpm:attributeDtypes", required=False)
    if attr_dtypes is not None:
        if len(attr_dtypes) != len(c.get("swpm:attributeNames", required=False) or []):
            c.add("SWPM_USD_STRIDE", "swpm:attributeNames and attributeDtypes differ in length")
        problem = dtype_problem("swpm:attributeDtypes", attr_dtypes, ATTRIBUTE_DTYPES)
        if problem is not None:  # (read casts to it: "V1000000000" would allocate 1 GB per element)
            c.add("SWPM_USD_TYPE", problem)

    V = len(points)
    vc = _array(values["swpm:vertexCounts"])
    tc = _array(values["swpm:triangleCounts"])
    err = _array(values["swpm:lodErrors"], np.float64)
    L = vc.shape[0]
    if L == 0 or tc.shape[0] != L or err.shape[0] != L:
        c.add(
            "SWPM_USD_LOD_TABLE",
            f"{L} vertexCounts, {tc.shape[0]} triangleCounts, {err.shape[0]} lodErrors",
            attrs=("swpm:vertexCounts", "swpm:triangleCounts", "swpm:lodErrors"),
        )
    else:
        if np.any(np.diff(vc) > 0) or np.any(np.diff(tc) > 0) or np.any(np.diff(err) < 0):
            c.add(
                "SWPM_USD_LOD_TABLE",
                "counts must not grow and errors must not shrink from LOD to LOD",
                attrs=("swpm:vertexCounts", "swpm:triangleCounts", "swpm:lodErrors"),
            )
        if int(vc[0]) != V:
            c.add(
                "SWPM_USD_LOD_TABLE",
                f"vertexCounts[0] = {int(vc[0])} but the prim has {V} points",
                attrs=("swpm:vertexCounts", "points"),
            )

    _check_index_width(c, V, params)

    names = [str(n) for n in values["swpm:bufferNames"]]
    dtypes = [str(d) for d in values["swpm:bufferDtypes"]]
    cols = _array(values["swpm:bufferColumns"])
    if not len(names) == len(dtypes) == cols.shape[0]:
        c.add("SWPM_USD_STRIDE", "swpm:bufferNames, bufferDtypes and bufferColumns differ in length")
        return c.found
    problem = dtype_problem("swpm:bufferDtypes", dtypes, BUFFER_DTYPES)
    if problem is not None:
        c.add("SWPM_USD_TYPE", problem)
        return c.found
    fields = [COLLAPSE_PREFIX + _snake(str(f)) for f in (c.get("swpm:collapseRecordFields", False) or [])]
    buffers: dict[str, np.ndarray] = {}
    structural = len(c.found)
    if fields:
        table = c.get("swpm:collapseRecords")
        if table is None:
            return c.found
        table = _array(table)
        if table.shape[0] % len(fields):
            c.add(
                "SWPM_USD_STRIDE",
                f"swpm:collapseRecords has {table.shape[0]} entries for {len(fields)} fields",
                attrs=("swpm:collapseRecords", "swpm:collapseRecordFields"),
            )
            return c.found
        table = table.reshape(-1, len(fields))
        buffers.update({f: table[:, i] for i, f in enumerate(fields)})
    for name, width in zip(names, cols.tolist(), strict=True):
        if name in buffers:
            continue
        a = c.get(attr_name(name))
        if a is None:
            continue
        a = _array(a)
        if width and a.shape[0] % width:
            c.add(
                "SWPM_USD_STRIDE",
                f"{attr_name(name)} has {a.shape[0]} entries, not a multiple of {width}",
                attrs=(attr_name(name),),
            )
            continue
        buffers[name] = a.reshape(-1, width) if width else a
    if len(c.found) > structural:
        return c.found

    from ..encode.base import ENCODINGS as _E

    restart = {
        v for k, v in params.items() if "restart" in k and isinstance(v, int) and not isinstance(v, bool)
    }
    cls_restart = getattr(_E.get(encoding), "restart_index", None)
    if cls_restart is not None:
        restart.add(int(cls_restart))
    for name in _VERTEX_BUFFERS:
        a = buffers.get(name)
        if a is None or a.size == 0:
            continue
        bad = a >= V
        if restart:
            bad &= ~np.isin(a, list(restart))
        if bad.any():
            i = int(np.argmax(bad))
            c.add(
                "SWPM_USD_INDEX_RANGE",
                f"{attr_name(name)}[{i}] = {int(a.reshape(-1)[i])} >= {V} vertices",
                attrs=(_stored_in(name, fields), "points"),
            )
    if "window_records" in buffers:
        w = buffers["window_records"].reshape(-1, 3)
        pool = buffers.get("index_pool", np.zeros(0, np.int64))
        if w.shape[0] != L:
            c.add(
                "SWPM_USD_STRIDE",
                f"swpm:windowRecords has {w.shape[0]} rows for {L} LODs",
                attrs=("swpm:windowRecords", "swpm:vertexCounts"),
            )
        # a strip pool's windows are index counts long (spec/format.md 3.5), a list's 3 x its triangles; a
        # strip prim without one count per window is reported as such (measured as a list pool instead, its
        # windows were said to lie outside indexPool, which named the wrong attribute)
        strip = params.get("primitive") == "strip"
        n = buffers["window_index_counts"].reshape(-1) if strip and "window_index_counts" in buffers else None
        if strip and n is None:
            c.add(
                "SWPM_USD_MISSING",
                "swpm:windowIndexCounts has no value; swpm:params primitive 'strip' needs one index count "
                "per window",
                attrs=("swpm:params",),
            )
        elif n is not None and n.shape[0] != w.shape[0]:
            c.add(
                "SWPM_USD_STRIDE",
                f"swpm:windowIndexCounts has {n.shape[0]} entries for {w.shape[0]} windows",
                attrs=("swpm:windowIndexCounts", "swpm:windowRecords"),
            )
        else:  # (windows measurable: a list pool, or a strip pool with one index count per window)
            end = w[:, 0] + (3 * w[:, 1] if n is None else n)
            out = end > pool.shape[0]
            if out.any():
                k = int(np.argmax(out))
                c.add(
                    "SWPM_USD_WINDOW_RANGE",
                    f"window of LOD {k} [{int(w[k, 0])}, {int(end[k])}) outside indexPool of {pool.shape[0]}",
                    attrs=("swpm:windowRecords", "swpm:indexPool")
                    + (("swpm:windowIndexCounts",) if n is not None else ()),
                )
        if (w[:, 2] > V).any():
            k = int(np.argmax(w[:, 2] > V))
            c.add(
                "SWPM_USD_INDEX_RANGE",
                f"window of LOD {k} uses {int(w[k, 2])} vertices of {V}",
                attrs=("swpm:windowRecords", "points"),
            )
    if "collapse_change_offsets" in buffers and "collapse_change_count" in buffers:
        if int(buffers["collapse_change_count"].sum()) != buffers["collapse_change_offsets"].shape[0]:
            c.add(
                "SWPM_USD_STRIDE",
                "collapse change counts do not sum to the number of change offsets",
                attrs=("swpm:collapseRecords", "swpm:collapseChangeOffsets"),
            )

    fvc = prim.GetAttribute("faceVertexCounts").Get()
    fvi = prim.GetAttribute("faceVertexIndices").Get()
    if fvc is None or fvi is None:
        c.add("SWPM_USD_TOPOLOGY", "faceVertexCounts / faceVertexIndices have no value")
    else:
        fvc, fvi = _array(fvc), _array(fvi)
        if fvc.size and (fvc != 3).any():
            c.add("SWPM_USD_TOPOLOGY", "faceVertexCounts are not all 3")
        elif fvi.shape[0] != 3 * fvc.shape[0] or (L and fvc.shape[0] not in set(tc.tolist())):
            c.add("SWPM_USD_TOPOLOGY", f"{fvc.shape[0]} faces match no LOD's triangle count")
        elif fvi.size and (fvi.min() < 0 or fvi.max() >= V):
            c.add("SWPM_USD_INDEX_RANGE", f"faceVertexIndices outside [0, {V})")
    if not c.found:
        try:
            from .reader import read

            read(prim)
        except Exception as e:  # any failure of the encoding's constructor
            c.add("SWPM_USD_REBUILD", f"{type(e).__name__}: {e}")
    return c.found
