"""Validation of SwpmMeshAPI prims, registered as a UsdValidation validator, plus a stage-level runner.

:func:`validate_prim` checks one prim against the invariants of the format (windows inside the pool,
indices below the vertex count, a known encoding, consistent strides and types) and returns
:class:`Finding` objects with stable codes (listed in ``CODES`` and spec/usd.md). :func:`register_validators`
registers it as the UsdValidation prim validator ``swpmValidators:SwpmMeshChecker``; :func:`validate_stage`
runs it together with usd-core's built-in validators on a stage (instance proxies included). The
checks themselves (:func:`validate_prim`, :class:`Finding`, ``CODES``) are :mod:`.prim_checks`'s, re-exported
here; this module registers them, checks each instance prototype once, and runs the stage.
"""

from __future__ import annotations

import contextlib
import os
import re
import threading
from collections.abc import Iterator
from typing import Any

from pxr import Tf, Usd, UsdValidation

from ..fileio import missing_file_problem
from ..format.errors import Problem, Report
from .prim_checks import CODES, ERROR, WARNING, Finding, validate_prim
from .reader import is_encoded

VALIDATOR_NAME = "swpmValidators:SwpmMeshChecker"


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
    """Run our validator and (``builtin``) usd-core's built-in validators on a stage; our output has none
    (usd-core's warnings of what a finding reports are dropped: :func:`_reported_warnings_trapped`)."""
    with _reported_warnings_trapped() as missing:
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
        return _validated(path, stage, builtin, missing)


#: usd-core's warnings (posted to stderr) a validation reports as findings: a layer the stage names that does
#: not open, as the stage's open reports its composition error (``SWPM_USD_LAYER_MISSING``, and usd-core's
#: own CompositionError), and a dependency that does not resolve (the MissingReferenceValidator's finding,
#: whose site it makes of the file's path: "Ill-formed SdfPath </tmp/a-b/x.usdc>" for a path with a '-')
_REPORTED_WARNINGS = (
    ("UsdStage::_ReportErrors", ("Could not open asset @", "Could not load sublayer @")),
    ("_EnqueueDependency", ("Failed to resolve reference @",)),
)


def _is_reported(diagnostic: Any, layers: set[str]) -> bool:
    where, what = str(diagnostic.sourceFunction), str(diagnostic.commentary)
    if where.endswith("::SdfPath") and what.startswith("Ill-formed SdfPath <"):
        return what[len("Ill-formed SdfPath <") :].split(">", 1)[0] in layers
    return any(where.endswith(fn) and any(t in what for t in texts) for fn, texts in _REPORTED_WARNINGS)


@contextlib.contextmanager
def _reported_warnings_trapped() -> Iterator[set[str]]:
    """The block's usd-core warnings a finding reports (:data:`_REPORTED_WARNINGS`; the block adds the layers
    it reports missing to the set it is given) dropped: they reached stderr beside the report ("Warning: in
    _ReportErrors at line 3326 of .../stage.cpp -- ..."). Every other diagnostic is posted as before, and
    errors still raise (``Tf.DiagnosticTrap``, usd-core 26; without it, nothing is trapped)."""
    layers: set[str] = set()
    trap = getattr(Tf, "DiagnosticTrap", None)
    if trap is None:  # pragma: no cover - an older usd-core
        yield layers
        return
    with trap() as trapped:
        try:
            yield layers
        finally:
            trapped.EraseMatching(lambda d: _is_reported(d, layers))


_MISSING_LAYER_ERRORS = ("ErrorInvalidAssetPath", "ErrorInvalidSublayerPath")


def _missing_layers(stage: Usd.Stage, layers: set[str]) -> list[Finding]:
    """A ``SWPM_USD_LAYER_MISSING`` for each sublayer, reference or payload of ``stage`` that does not open:
    the prims it brings are not on the stage (usd-core warned on stderr; ``--no-builtin`` said "valid"). Each
    layer's path added to ``layers``."""
    out = []
    for err in stage.GetCompositionErrors():
        if type(err).__name__ not in _MISSING_LAYER_ERRORS:
            continue
        text = str(err)
        asset = re.search(r"@([^@]+)@", text)
        layer = asset.group(1) if asset else "?"
        kind = re.search(r" for (reference|payload) introduced by ", text)
        site = getattr(getattr(err, "rootSite", None), "path", None)
        prim = "/" if site is None or site.isEmpty else str(site.StripAllVariantSelections().GetPrimPath())
        why = missing_file_problem(layer) if not os.path.exists(layer) else "it does not open as a USD layer"
        arc = kind.group(1) if kind else "sublayer"
        layers.add(layer)
        out.append(
            Finding("SWPM_USD_LAYER_MISSING", ERROR, prim or "/", f"{arc} {layer}: {why} (usd-core: {text})")
        )
    return out


def _validated(
    path: str | os.PathLike[str] | Usd.Stage, stage: Usd.Stage, builtin: bool, missing: set[str]
) -> list[Finding]:
    """:func:`validate_stage`'s findings on the open ``stage`` (``path``: as it was given; ``missing``: the
    layers found missing, added)."""
    reg = UsdValidation.ValidationRegistry()
    names = _builtin_names(reg) if builtin else []
    ours = register_validators()
    if ours:
        names.append(VALIDATOR_NAME)
    findings: list[Finding] = _missing_layers(stage, missing)
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
