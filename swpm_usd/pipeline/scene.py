"""The run's scene layer (``<output>/scene.usda``): one Xform per asset, referencing its USD layer.

:func:`_write_scene` authors it on an Sdf layer (no stage: none of the asset layers is opened), each prim
named from its asset's output stem alone (:func:`_scene_prim_name`: a non-ASCII one as usd-core 0.26 takes
UTF-8 identifiers) and corrected to the scene's up axis and
units where its layer says otherwise (:func:`_author_units_correction`, from the units its manifest record
holds: :func:`_layer_with_units`). Separate from the runner: the only USD the run itself writes.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import TYPE_CHECKING

from ..usd.names import valid_identifier as _valid_identifier  # (a module global: tests patch it here)
from .worker import LAYER_UNIT_KEYS, recorded_layer_units

if TYPE_CHECKING:  # (pxr is imported where a USD output is written: a run without one never loads it)
    from pxr import Sdf


def _layer_with_units(out_dir: Path, layer: dict) -> dict | None:
    """``layer`` (the record of an asset's USD layer, intact) as the scene needs it, with the layer's units
    (:data:`.worker.LAYER_UNIT_KEYS`): itself when it has them; a copy with those the layer's metadata
    authors when it has none, a record of 0.7.2 written before they were (the scene referenced the layer
    uncorrected: :func:`.worker.recorded_layer_units`); None when they do not read."""
    if all(k in layer for k in LAYER_UNIT_KEYS):
        return layer
    units = recorded_layer_units(out_dir / layer["path"])
    return None if units is None else {**layer, **units}


#: the key of the scene's ``run_outputs`` record, True when the scene names a prim by a non-ASCII stem USD
#: takes as it is (:func:`_utf8_named`): a scene recorded without it was written when such a name was
#: mangled (``café`` -> ``caf___`` and a hash) and is written again, though no record changed; a scene of
#: ASCII names alone is recorded as before
UTF8_PRIM_NAMES = "utf8_prim_names"


def _utf8_named(stems: list[str]) -> bool:
    """Does a scene of the asset layers ``<stem>.usdc`` name a prim by a non-ASCII name USD takes, one that
    ``Tf.MakeValidIdentifier`` (ASCII's) mangled before (:data:`UTF8_PRIM_NAMES`)?"""
    for stem in stems:
        if stem.isascii():  # (pxr not imported for a scene of ASCII names: a rerun keeping it loads none)
            continue
        from pxr import Tf

        if _valid_identifier(stem) != Tf.MakeValidIdentifier(stem):
            return True
    return False


def _scene_stems(records: dict[str, dict]) -> list[str]:
    """The stems of the asset layers a scene of ``records`` references, in its order."""
    return [Path(path).stem for path, _ in _scene_layers(records)]


def _scene_layers(records: dict[str, dict]) -> list[tuple[str, dict]]:
    """The asset layers a scene of ``records`` (asset id -> manifest record) references: (path, record)."""
    return [
        (r["outputs"]["usd"]["path"], r["outputs"]["usd"])
        for k, r in sorted(records.items())
        if r.get("status") == "built" and "usd" in r.get("outputs", {})
    ]


def _scene_prim_name(stem: str, used: set[str]) -> str:
    """The scene's prim for the asset layer ``<stem>.usdc``: the stem itself where it is a valid identifier
    (stems are unique: they are file names in output.dir; a non-ASCII one USD takes, ``café``, too), else
    the identifier made of it (:func:`_valid_identifier`) and a hash of the stem (``a-b`` and ``a b`` both
    make ``a_b``). A name depends on its own asset alone, so a layer that overrides ``/Scene/cow`` still finds
    it when assets come or go (an index in the name shifted)."""
    base = _valid_identifier(stem)
    names = [base] if base == stem else []
    digest = hashlib.sha256(stem.encode()).hexdigest()
    names += [f"{base}_{digest[:size]}" for size in (8, 16, 64)]  # (taken by another's hashed name: 2^-32)
    name = next(n for n in names if n not in used)
    used.add(name)
    return name


def _write_scene(out_dir: Path, records: dict[str, dict]) -> None:
    """A scene layer that references every per-asset USD layer, one Xform each.

    Authored on the layer itself (Sdf), never on a stage: a stage composes each reference as it is added,
    opening every asset layer (5,000 assets: 20 s and 350 MB, on every run, a rerun with nothing to build
    included); the layer written is the same text."""
    from pxr import Sdf

    from ..fileio import fill_layer_replacing

    layers = _scene_layers(records)

    def fill(layer: Sdf.Layer) -> None:
        with Sdf.ChangeBlock():
            layer.pseudoRoot.SetInfo("upAxis", "Y")  # (UsdGeom.SetStageUpAxis, SetStageMetersPerUnit)
            layer.pseudoRoot.SetInfo("metersPerUnit", 1.0)
            root = Sdf.PrimSpec(layer.pseudoRoot, "Scene", Sdf.SpecifierDef, "Xform")
            # an assembly: each asset's root is a component model, a model only under group models (without
            # it no asset of the scene was one, IsModel() False: model traversal, selection, draw modes)
            root.SetInfo("kind", "assembly")
            layer.defaultPrim = "Scene"
            used: set[str] = set()
            for path, usd_record in layers:
                prim = Sdf.PrimSpec(root, _scene_prim_name(Path(path).stem, used), Sdf.SpecifierDef, "Xform")
                prim.referenceList.Prepend(Sdf.Reference(f"./{path}"))
                _author_units_correction(prim, usd_record.get("up_axis"), usd_record.get("meters_per_unit"))

    # (renamed over the scene once saved, which keeps its mode; a caller of run may have it open: reloaded.
    # The layer is bound in fill's frame alone: a LayerReloadError kept does not keep it alive)
    fill_layer_replacing(out_dir / "scene.usda", out_dir / ".scene.tmp.usda", fill)


#: the scene's up axis and metersPerUnit (USD converts neither across a reference: each asset whose layer
#: says otherwise gets a corrective transform on its prim, :func:`_author_units_correction`)
SCENE_UP_AXIS, SCENE_METERS_PER_UNIT = "Y", 1.0
#: the corrective ops' names (suffixed: beside, not instead of, a layout's own xformOp:translate ...)
UP_AXIS_OP, UNITS_OP = "xformOp:rotateX:swpmUpAxis", "xformOp:scale:swpmMetersPerUnit"


def _author_units_correction(prim: Sdf.PrimSpec, up_axis: str | None, meters_per_unit: float | None) -> None:
    """On the scene's prim ``prim`` (an Sdf.PrimSpec referencing an asset layer of ``up_axis`` and
    ``meters_per_unit``, its manifest record's; None for a record that has neither, one of an earlier version
    taken as the scene's), the transform that puts the asset in the scene's units: a uniform scale of
    ``meters_per_unit / SCENE_METERS_PER_UNIT`` and, for a Z-up asset, -90 degrees about X (its +Z becomes
    the scene's +Y), in that order (scale applied to the points first). The asset's own root (the Xform
    :func:`.usd.write` makes) authors no xformOps, so the prim's ``xformOpOrder`` replaces none. What was
    applied is in the prim's customData too (``swpm:assetUpAxis``, ``swpm:assetMetersPerUnit``, as
    ``GetCustomDataByKey`` names them)."""
    from pxr import Gf, Sdf, Vt

    ops = []
    rotate = up_axis is not None and up_axis != SCENE_UP_AXIS
    scale = meters_per_unit is not None and float(meters_per_unit) != SCENE_METERS_PER_UNIT
    if rotate:
        attr = Sdf.AttributeSpec(prim, UP_AXIS_OP, Sdf.ValueTypeNames.Double)
        attr.default = -90.0
        ops.append(UP_AXIS_OP)
    if scale:
        s = float(meters_per_unit) / SCENE_METERS_PER_UNIT
        attr = Sdf.AttributeSpec(prim, UNITS_OP, Sdf.ValueTypeNames.Double3)
        attr.default = Gf.Vec3d(s, s, s)
        ops.append(UNITS_OP)
    if not ops:
        return
    order = Sdf.AttributeSpec(prim, "xformOpOrder", Sdf.ValueTypeNames.TokenArray, Sdf.VariabilityUniform)
    order.default = Vt.TokenArray(ops)
    applied = {"assetUpAxis": up_axis, "assetMetersPerUnit": meters_per_unit}
    prim.customData = {"swpm": {k: v for k, v in applied.items() if v is not None}}
