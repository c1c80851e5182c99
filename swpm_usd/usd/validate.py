"""Validation of SwpmMeshAPI prims, registered as a UsdValidation validator, plus a stage-level runner.

:func:`validate_prim` checks one prim against the invariants of the format (windows inside the pool,
indices below the vertex count, a known encoding, consistent strides and types) and returns
:class:`Finding` objects with stable codes (listed in ``CODES`` and spec/usd.md). :func:`register_validators`
registers it as the UsdValidation prim validator ``swpmValidators:SwpmMeshChecker``; :func:`validate_stage`
runs it together with usd-core's built-in validators on a stage (instance proxies included).
"""

from __future__ import annotations

import os
import re
import threading
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from pxr import Usd, UsdGeom, UsdValidation

from ..fileio import missing_file_problem
from ..format.errors import Problem, Report
from ..format.layout import INDEX_ARRAYS, draw_index_width
from ..format.meta import parse_meta_json
from .arrays import ATTRIBUTE_DTYPES, BUFFER_DTYPES, dtype_problem
from .reader import _snake, authored_type, is_encoded, stored_value
from .schema import COLLAPSE_PREFIX, ENCODING_TOKENS, FORMAT_VERSION, PROPERTY_TYPES, attr_name

VALIDATOR_NAME = "swpmValidators:SwpmMeshChecker"
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


_registered = False

#: while :func:`validate_stage` runs on a stage: the check of each instance prototype's prim, prim path in
#: the prototype -> :class:`_Checked` (proxy path it was made at, findings), one memo per call, kept under the
#: stage (the stage itself, alive during the call: an identifier would be reused, a root layer's and an
#: anonymous session layer's address alike, once the stage is gone) and dropped when the call returns, so
#: a later call never sees findings of a stage since edited or of another stage. Every instance proxy of one
#: prototype has the prototype's values, so a crowd of 500 instances of one asset is checked once, not 500
#: times (each a full read of the buffers: 5.8-15.3 s, now 1.5-2.4 s). Module globals, not context
#: variables: usd-core calls the validator from its own worker threads.
_memos: dict[Usd.Stage, list[dict[str, _Checked]]] = {}
_memo_lock = threading.Lock()
#: how long a worker waits for another's check of the same prototype prim before checking it itself
_MEMO_WAIT_SECONDS = 60.0


class _Checked:
    """One prototype prim's check in a memo: the thread making it, then the proxy path and the findings
    (``None`` until made, and if the check raised)."""

    __slots__ = ("by", "done", "result")

    def __init__(self) -> None:
        self.by = threading.get_ident()
        self.done = threading.Event()
        self.result: tuple[str, list[Finding]] | None = None


def _validate_cached(prim: Usd.Prim) -> list[Finding]:
    """:func:`validate_prim`, once per instance prototype while :func:`validate_stage` runs on ``prim``'s
    stage (the findings of another proxy of the prototype, their prim paths and messages naming this one).
    A worker reaching a prototype prim another is checking waits for that check rather than repeating it:
    every worker thread starting on a crowd read the buffers once each (as many reads as cores)."""
    if not _memos or not prim.IsInstanceProxy() or not is_encoded(prim):
        return validate_prim(prim)
    key = str(prim.GetPrimInPrototype().GetPath())
    with _memo_lock:
        calls = _memos.get(prim.GetStage())
        memo = calls[-1] if calls else None  # (the latest call's: it read the stage as it is now)
        if memo is None:
            entry, mine = None, False
        else:
            entry = memo.get(key)
            mine = entry is None
            if mine:
                entry = memo[key] = _Checked()
    here = str(prim.GetPath())
    if entry is None:
        return validate_prim(prim)
    if mine:
        try:
            found = validate_prim(prim)
            entry.result = (here, found)
        finally:
            entry.done.set()
        return found
    if not entry.done.is_set():
        # (the thread making the check, re-entered while making it, does not wait for itself; nor does anyone
        # wait forever)
        if entry.by == threading.get_ident() or not entry.done.wait(_MEMO_WAIT_SECONDS):
            return validate_prim(prim)
    if entry.result is None:  # (the check raised: this proxy's own raises the same)
        return validate_prim(prim)
    there, found = entry.result
    return [Finding(f.code, f.severity, here, f.message.replace(there, here)) for f in found]


def _validator_fn(prim: Usd.Prim, *_: Any) -> list[Any]:
    errors = []
    for f in _validate_cached(prim):
        kind = (
            UsdValidation.ValidationErrorType.Error
            if f.severity == ERROR
            else UsdValidation.ValidationErrorType.Warn
        )
        site = UsdValidation.ValidationErrorSite(prim.GetStage(), prim.GetPath())
        errors.append(UsdValidation.ValidationError(f.code, kind, [site], f.message))
    return errors


def register_validators() -> bool:
    """Register ``swpmValidators:SwpmMeshChecker`` with UsdValidation (once); False if usd-core cannot."""
    global _registered
    if _registered:
        return True
    reg = UsdValidation.ValidationRegistry()
    if not reg.HasValidator(VALIDATOR_NAME):
        meta = UsdValidation.ValidatorMetadata(
            name=VALIDATOR_NAME,
            keywords=["swpm", "SwpmMeshAPI"],
            doc="SwpmMeshAPI invariants: " + " ".join(f"{k}: {v}" for k, v in CODES.items()),
        )
        try:
            reg.RegisterPrimValidator(meta, _validator_fn)
        except Exception:  # pragma: no cover - registration API differs
            return False
    _registered = True
    return True


def _builtin_names(reg: Any) -> list[str]:
    return [
        m.name
        for m in reg.GetAllValidatorMetadata()
        if "UsdzValidators" not in m.GetKeywords()
        and m.name != "usdUtilsValidators:RootPackageValidator"
        and m.name != VALIDATOR_NAME
        and not m.isSuite
    ]


def _site_path(err: Any, stage: Usd.Stage) -> str:
    """The prim a usd-core finding is about: its site's prim or property, or the prim of a layer spec it
    names (usdValidation:AttributeTypeMismatch's site is the attribute's spec in a layer, no stage object: it
    was reported at ``/``) when that layer is in the stage's own layer stack, where a spec's path is the
    prim's; else ``/`` (a referenced layer's paths are not the stage's)."""
    stack = None
    for site in err.GetSites():
        if site.IsPrim() or site.IsProperty():
            return str(site.GetPrim().GetPath() if site.IsPrim() else site.GetProperty().GetPath())
        spec = site.GetPropertySpec() or site.GetPrimSpec()
        if spec:
            stack = stack if stack is not None else {layer.identifier for layer in stage.GetLayerStack()}
            if spec.layer.identifier in stack:
                return str(spec.path.GetPrimPath())
    return "/"


def _tf_messages(text: str) -> str:
    """The messages of a ``Tf.ErrorException`` text ("Error in 'F' at line N in file S : 'message'", one per
    error), without pxr's namespace names, joined by "; "."""
    out = []
    for part in re.split(r"\s*Error in ", text.strip()):
        msg = part.split(" : '", 1)[1] if " : '" in part else part
        msg = re.sub(r"pxrInternal_\w+?__pxrReserved__::", "", msg.strip().rstrip("'").strip())
        if msg:
            out.append(msg)
    return "; ".join(out)


def _open(path: str) -> tuple[Usd.Stage | None, str]:
    """The stage at ``path``, or None and why usd-core cannot open it (naming the file)."""
    try:
        stage = Usd.Stage.Open(path)
        reason = "" if stage is not None else "usd-core returned no stage"
    except Exception as exc:  # noqa: BLE001 - pxr raises Tf.ErrorException (and others) for a bad layer
        stage = None
        reason = _tf_messages(str(exc)) or type(exc).__name__
    if stage is not None:
        return stage, ""
    hint = ""
    try:
        with open(path, "rb") as f:
            head = f.read(8)
        if not head:
            hint = " (the file is empty)"
        elif head.startswith(b"SWPM"):
            hint = " (it is an SWPM file: give it a .swpm name to read it as one)"
    except OSError as exc:
        hint = f" ({exc.strerror or exc})"
    return None, f"{path}: usd-core cannot open it as a USD layer{hint}: {reason}"


def stage_report(path: str | os.PathLike[str]) -> Report:
    """:func:`validate_stage` (builtin validators too) as the SWPM reader's :class:`Report`, what
    :func:`swpm_usd.validate` returns for a USD stage (it reported a bad magic): each finding's code and
    severity, its message after its prim path, no offset. A path that names no regular file is one
    ``SWPM_USD_OPEN`` in ``swpm-pipeline validate``'s words (usd-core's were "Failed to open layer"), and a
    FIFO is never opened (its open would wait for a writer)."""
    rep = Report(path=os.fspath(path))
    if not os.path.isfile(path):
        why = "not a regular file" if os.path.exists(path) else missing_file_problem(path)
        rep.problems.append(Problem("SWPM_USD_OPEN", ERROR, why, None))
        return rep
    for f in validate_stage(path):
        rep.problems.append(Problem(f.code, f.severity, f"{f.prim}: {f.message}", None))
    return rep


def validate_stage(path: str | os.PathLike[str] | Usd.Stage, builtin: bool = True) -> list[Finding]:
    """Run our validator and (``builtin``) usd-core's built-in validators on a stage; our output has none."""
    if isinstance(path, Usd.Stage):
        stage = path
    else:
        from .probe import checked

        # a corrupt crate file can crash usd-core (SIGSEGV) or make it ask for a giant allocation: opened
        # first in a probe process, and here only if that ends cleanly (the text layers the check parsed
        # here held for the open: parsed once)
        with checked(path) as probed:
            if probed is not None:
                kinds = {"open": "SWPM_USD_OPEN", "read": "SWPM_USD_READ", "probe": "SWPM_USD_PROBE"}
                code = kinds.get(probed.kind, "SWPM_USD_CRASH")
                return [Finding(code, ERROR, "/", probed.message)]
            stage, problem = _open(os.fspath(path))
        if stage is None:
            return [Finding("SWPM_USD_OPEN", ERROR, "/", problem)]
    reg = UsdValidation.ValidationRegistry()
    names = _builtin_names(reg) if builtin else []
    ours = register_validators()
    if ours:
        names.append(VALIDATOR_NAME)
    findings: list[Finding] = []
    memo: dict[str, _Checked] = {}
    with _memo_lock:
        _memos.setdefault(stage, []).append(memo)
    try:
        _validate_into(findings, stage, reg, names, ours)
    except RuntimeError as exc:  # (pxr's Tf.ErrorException, for a value it cannot unpack; not a bug of ours)
        where = stage.GetRootLayer().identifier if isinstance(path, Usd.Stage) else os.fspath(path)
        reason = _tf_messages(str(exc)) or type(exc).__name__
        findings.append(Finding("SWPM_USD_READ", ERROR, "/", f"{where}: usd-core cannot read it: {reason}"))
    finally:
        with _memo_lock:
            calls = [m for m in _memos[stage] if m is not memo]  # (by identity: two empty memos are equal)
            if calls:
                _memos[stage] = calls
            else:
                del _memos[stage]
    findings.sort(key=lambda f: (f.prim, f.code, f.message))
    return findings


def _validate_into(findings: list[Finding], stage: Usd.Stage, reg: Any, names: list[str], ours: bool) -> None:
    """:func:`validate_stage`'s findings, appended to ``findings`` as they come."""
    if names:
        ctx = UsdValidation.ValidationContext(reg.GetOrLoadValidatorsByName(names))
        for err in ctx.Validate(stage):
            if err.HasNoError():
                continue
            validator = err.GetValidator()
            vname = validator.GetMetadata().name if validator else ""
            severity = ERROR if err.GetType() == UsdValidation.ValidationErrorType.Error else WARNING
            if vname == VALIDATOR_NAME:
                code = str(err.GetName()).rsplit(".", 1)[-1]
            else:
                code = f"{vname}.{err.GetName()}" if str(err.GetName()) else vname
            findings.append(Finding(code, severity, _site_path(err, stage), err.GetMessage()))
    if not ours:
        rng = Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate))
        for prim in rng:
            findings.extend(_validate_cached(prim))


def report(findings: list[Finding]) -> dict[str, Any]:
    """JSON-able report: counts per severity and the findings."""
    return {
        "errors": sum(f.severity == ERROR for f in findings),
        "warnings": sum(f.severity == WARNING for f in findings),
        "findings": [f.to_dict() for f in findings],
    }
