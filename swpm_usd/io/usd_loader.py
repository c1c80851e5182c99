"""Load USD stages (.usd .usda .usdc .usdz) through usd-core into a cleaned :class:`~swpm_usd.mesh.Mesh`.

Every ``UsdGeom.Mesh`` prim under the pseudo-root (or under ``prim_path``), instance proxies included, that a
renderer draws (not invisible, not of purpose ``guide`` or ``proxy``, not every face a hole) is read at its
earliest time sample, moved to world space with its local-to-world transform and concatenated. A
``PointInstancer``'s prototypes are drawn at each of its instances (their masks applied), not as themselves.
Polygons are fan-triangulated and faces listed in ``holeIndices`` (not rendered) left out;
``orientation = leftHanded`` (and mirroring transforms) flip the winding so front faces come out
counter-clockwise. Primvars:
``primvars:normals`` (else the ``normals`` attribute) -> ``normal``, ``primvars:st`` (else the first
texCoord2f[] primvar by name) -> ``uv``, ``primvars:displayColor`` (+ ``displayOpacity`` as alpha) ->
``color``. Indexed primvars are flattened. ``vertex`` / ``varying`` / ``constant`` values stay per point;
``faceVarying`` / ``uniform`` values are taken per face corner and each distinct (point, values) pair becomes
one vertex, so only real seams split points. Any USD failure, a composition error (a sublayer or reference
that does not resolve, on an active prim in or above the loaded subtree) too, becomes a
:class:`~swpm_usd.errors.MeshLoadError` naming the file.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom

from ..errors import MeshLoadError, first_few, tf_message
from ..mesh import Mesh
from . import over_budget
from .clean import Part, clean_mesh, concatenate_parts, rgba_float, split_corners, transform_part

_TEXCOORD2_TYPES = {
    Sdf.ValueTypeNames.TexCoord2fArray,
    Sdf.ValueTypeNames.TexCoord2dArray,
    Sdf.ValueTypeNames.TexCoord2hArray,
}


class _Invalid(ValueError):
    """Something in the stage's data is not a valid mesh (the message says what and where)."""


class _Topology:
    """Fan triangulation of one mesh prim: corner indices of every triangle and the face each comes from."""

    def __init__(
        self,
        counts: np.ndarray,
        indices: np.ndarray,
        n_points: int,
        left_handed: bool,
        where: str,
        holes: np.ndarray | None = None,
    ):
        if counts.shape[0] and counts.min() < 3:
            face = int(np.argmax(counts < 3))
            raise _Invalid(f"{where}: face {face} has {int(counts[face])} vertices (at least 3 needed)")
        if int(counts.sum()) != indices.shape[0]:
            raise _Invalid(
                f"{where}: faceVertexCounts sum to {int(counts.sum())} "
                f"but there are {indices.shape[0]} faceVertexIndices"
            )
        if indices.shape[0] and (indices.min() < 0 or indices.max() >= n_points):
            bad = int(np.argmax((indices < 0) | (indices >= n_points)))
            raise _Invalid(
                f"{where}: faceVertexIndices[{bad}] = {int(indices[bad])} out of range for {n_points} points"
            )
        self.n_faces = counts.shape[0]
        self.n_corners_in = indices.shape[0]
        self.n_points = n_points
        ntri = counts - 2
        if holes is not None and holes.shape[0]:
            if holes.min() < 0 or holes.max() >= self.n_faces:
                bad = int(np.argmax((holes < 0) | (holes >= self.n_faces)))
                raise _Invalid(
                    f"{where}: holeIndices[{bad}] = {int(holes[bad])} out of range for {self.n_faces} faces"
                )
            ntri = ntri.copy()
            ntri[holes] = 0  # a hole face is not rendered: no triangles (its corners keep their numbers)
        starts = np.cumsum(counts) - counts
        self.face = np.repeat(np.arange(self.n_faces, dtype=np.int64), ntri)
        k = np.arange(self.face.shape[0], dtype=np.int64) - (np.cumsum(ntri) - ntri)[self.face] + 1
        c0 = starts[self.face]
        order = (0, 2, 1) if left_handed else (0, 1, 2)
        # corner (face-vertex) index of every triangle corner, (T, 3)
        self.corners = np.stack([c0, c0 + k, c0 + k + 1], axis=1)[:, order]
        self.points = indices[self.corners]

    def resolve(self, values: np.ndarray, interpolation: str, what: str) -> tuple[str, np.ndarray]:
        """Primvar values -> ("point", (V, k)) or ("corner", (3T, k))."""
        values = values.reshape(values.shape[0], -1)
        n = values.shape[0]
        expected = {
            UsdGeom.Tokens.constant: 1,
            UsdGeom.Tokens.uniform: self.n_faces,
            UsdGeom.Tokens.vertex: self.n_points,
            UsdGeom.Tokens.varying: self.n_points,
            UsdGeom.Tokens.faceVarying: self.n_corners_in,
        }.get(interpolation)
        if expected is None:
            raise _Invalid(f"{what} has unknown interpolation {interpolation!r}")
        if n < expected or (n != expected and interpolation != UsdGeom.Tokens.constant):
            raise _Invalid(f"{what} ({interpolation}) has {n} values, expected {expected}")
        if interpolation == UsdGeom.Tokens.constant:
            return "point", np.broadcast_to(values[:1], (self.n_points, values.shape[1]))
        if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying):
            return "point", values
        if interpolation == UsdGeom.Tokens.uniform:
            return "corner", np.repeat(values[self.face], 3, axis=0)
        return "corner", values[self.corners.reshape(-1)]

    def to_corner(self, resolved: tuple[str, np.ndarray]) -> np.ndarray:
        kind, values = resolved
        return values if kind == "corner" else values[self.points.reshape(-1)]


def _primvar(api: UsdGeom.PrimvarsAPI, name: str) -> UsdGeom.Primvar | None:
    pv = api.GetPrimvar(name)
    return pv if pv and pv.HasValue() else None


def _primvar_values(
    pv: UsdGeom.Primvar, topo: _Topology, time: Usd.TimeCode, where: str
) -> tuple[str, np.ndarray] | None:
    what = f"{where}: primvar {pv.GetPrimvarName()!r}"
    if pv.GetElementSize() != 1:
        warnings.warn(f"{what} has elementSize {pv.GetElementSize()}; ignored", stacklevel=4)
        return None
    if pv.IsIndexed():
        raw, indices = pv.Get(time), pv.GetIndices(time)
        n = 0 if raw is None else len(raw)
        idx = np.asarray(indices if indices is not None else [], dtype=np.int64)
        if idx.shape[0] and (idx.min() < 0 or idx.max() >= n):
            pos = int(np.argmax((idx < 0) | (idx >= n)))
            raise _Invalid(f"{what}: indices[{pos}] = {int(idx[pos])} out of range for {n} values")
    flat = pv.ComputeFlattened(time)
    if flat is None:
        raise _Invalid(f"{what} could not be flattened")
    return topo.resolve(np.asarray(flat), pv.GetInterpolation(), what)


def _read_mesh(prim: Usd.Prim, time: Usd.TimeCode) -> Part | None:
    """``prim``'s triangles and attributes in its own space (the caller moves them to world space)."""
    where = str(prim.GetPath())
    mesh = UsdGeom.Mesh(prim)
    raw_points = mesh.GetPointsAttr().Get(time)
    raw_counts = mesh.GetFaceVertexCountsAttr().Get(time)
    raw_indices = mesh.GetFaceVertexIndicesAttr().Get(time)
    points = (
        np.zeros((0, 3)) if raw_points is None else np.asarray(raw_points, dtype=np.float64).reshape(-1, 3)
    )
    counts = np.zeros(0, np.int64) if raw_counts is None else np.asarray(raw_counts, dtype=np.int64)
    indices = np.zeros(0, np.int64) if raw_indices is None else np.asarray(raw_indices, dtype=np.int64)
    if counts.shape[0] == 0 and indices.shape[0] == 0:
        return None  # an empty placeholder mesh contributes nothing
    left = mesh.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded
    raw_holes = mesh.GetHoleIndicesAttr().Get(time)
    holes = None if raw_holes is None else np.asarray(raw_holes, dtype=np.int64)
    topo = _Topology(counts, indices, points.shape[0], left, where, holes)
    if topo.points.shape[0] == 0:
        return None  # every face a hole (_not_rendered has left such a mesh out already)

    api = UsdGeom.PrimvarsAPI(prim)
    found: dict[str, tuple[str, np.ndarray]] = {}

    pv = _primvar(api, "normals")
    if pv is not None:
        r = _primvar_values(pv, topo, time, where)
        if r is not None:
            found["normal"] = r
    elif mesh.GetNormalsAttr().HasValue():
        normals = mesh.GetNormalsAttr().Get(time)
        if normals is not None and len(normals):
            found["normal"] = topo.resolve(
                np.asarray(normals), mesh.GetNormalsInterpolation(), f"{where}: attribute 'normals'"
            )

    pv = _primvar(api, "st")
    if pv is None:
        tex = sorted(
            (p for p in api.GetPrimvarsWithValues() if p.GetTypeName() in _TEXCOORD2_TYPES),
            key=lambda p: str(p.GetPrimvarName()),
        )
        pv = tex[0] if tex else None
    if pv is not None:
        r = _primvar_values(pv, topo, time, where)
        if r is not None:
            if r[1].shape[1] != 2:
                raise _Invalid(f"{where}: uv primvar {pv.GetPrimvarName()!r} is not 2-component")
            found["uv"] = r

    pv = _primvar(api, "displayColor")
    if pv is not None:
        color = _primvar_values(pv, topo, time, where)
        opv = _primvar(api, "displayOpacity")
        opacity = None if opv is None else _primvar_values(opv, topo, time, where)
        if color is not None and opacity is not None:
            if color[0] == opacity[0] == "point":
                color = ("point", np.concatenate([color[1][:, :3], opacity[1][:, :1]], axis=1))
            else:
                rgb = topo.to_corner(color)[:, :3]
                color = ("corner", np.concatenate([rgb, topo.to_corner(opacity)[:, :1]], axis=1))
        if color is not None:
            found["color"] = (color[0], rgba_float(color[1]))

    point_attrs = {n: np.asarray(v, dtype=np.float32) for n, (kind, v) in found.items() if kind == "point"}
    corner_attrs = {n: np.asarray(v, dtype=np.float32) for n, (kind, v) in found.items() if kind == "corner"}
    if corner_attrs:
        vertex_point, triangles, attrs = split_corners(topo.points, corner_attrs)
        attrs.update({n: a[vertex_point] for n, a in point_attrs.items()})
        part = (points[vertex_point], triangles, attrs)
    else:
        part = (points, topo.points, point_attrs)
    return part


#: point instancers nested deeper than this (a prototype that instances itself) are an error
_MAX_INSTANCER_DEPTH = 16


def _drawn_meshes(
    root: Usd.Prim,
    predicate: object,
    to_world: Callable[[Usd.Prim], Gf.Matrix4d],
    xf_cache: UsdGeom.XformCache,
    time: Usd.TimeCode,
    depth: int = 0,
    proto_root: Usd.Prim | None = None,
) -> Iterator[tuple[Usd.Prim, Gf.Matrix4d, Usd.Prim | None]]:
    """Every Mesh prim of ``root``'s subtree with its local-to-world matrix and the prototype root it is
    drawn under (None: drawn as itself). A PointInstancer's children are not drawn as themselves (Hydra
    culls them) and its prototypes are drawn at each of its instances (mask and ``invisibleIds`` applied),
    wherever they are on the stage."""
    it = iter(Usd.PrimRange(root, predicate))
    for prim in it:
        if prim.IsA(UsdGeom.PointInstancer):
            it.PruneChildren()
            if _not_rendered(prim, time, proto_root) is not None:
                continue
            if depth >= _MAX_INSTANCER_DEPTH:
                raise _Invalid(f"{prim.GetPath()}: point instancers nested over {_MAX_INSTANCER_DEPTH} deep")
            yield from _instanced_meshes(prim, to_world(prim), xf_cache, time, depth)
        elif prim.IsA(UsdGeom.Mesh):
            yield prim, to_world(prim), proto_root


def _instanced_meshes(
    prim: Usd.Prim, to_world: Gf.Matrix4d, xf_cache: UsdGeom.XformCache, time: Usd.TimeCode, depth: int
) -> Iterator[tuple[Usd.Prim, Gf.Matrix4d, Usd.Prim | None]]:
    """The meshes a PointInstancer draws: each instance's prototype, moved by the instance's transform."""
    instancer = UsdGeom.PointInstancer(prim)
    targets = instancer.GetPrototypesRel().GetForwardedTargets()
    indices = instancer.GetProtoIndicesAttr().Get(time)
    if not targets or indices is None or len(indices) == 0:
        return
    ids = np.asarray(indices, dtype=np.int64)
    bad = (ids < 0) | (ids >= len(targets))
    if bad.any():
        i = int(np.argmax(bad))
        raise _Invalid(
            f"{prim.GetPath()}: protoIndices[{i}] = {int(ids[i])}, it has {len(targets)} prototypes"
        )
    xforms = instancer.ComputeInstanceTransformsAtTime(
        time, time, UsdGeom.PointInstancer.IncludeProtoXform, UsdGeom.PointInstancer.IgnoreMask
    )
    if xforms is None or len(xforms) != len(indices):
        raise _Invalid(f"{prim.GetPath()}: the point instancer's instance transforms do not compute")
    mask = instancer.ComputeMaskAtTime(time)
    stage = prim.GetStage()
    # (a prototype may sit under an `over` or a `class`: not defined, still drawn through the instancer)
    predicate = Usd.TraverseInstanceProxies(Usd.PrimIsActive & Usd.PrimIsLoaded)
    for i, proto_index in enumerate(ids.tolist()):
        if mask and not mask[i]:
            continue
        proto = stage.GetPrimAtPath(targets[proto_index])
        if not proto:
            raise _Invalid(f"{prim.GetPath()}: prototype {targets[proto_index]} is not on the stage")
        instance = xforms[i] * to_world

        def placed(q: Usd.Prim, proto: Usd.Prim = proto, instance: Gf.Matrix4d = instance) -> Gf.Matrix4d:
            # (the instance transform holds the prototype root's own transform)
            relative = Gf.Matrix4d(1.0) if q == proto else xf_cache.ComputeRelativeTransform(q, proto)[0]
            return relative * instance

        yield from _drawn_meshes(proto, predicate, placed, xf_cache, time, depth + 1, proto)


def _not_rendered(prim: Usd.Prim, time: Usd.TimeCode, proto_root: Usd.Prim | None = None) -> str | None:
    """Why a renderer does not draw ``prim`` (invisible, itself or through an ancestor; purpose guide, or
    proxy: a viewport stand-in for the render geometry; a Mesh whose ``holeIndices`` list every face), or None
    when it does. Drawn in a point instancer's prototype ``proto_root``, its ancestors above that root do
    not count (as in UsdImaging: prototypes are often kept under an invisible scope)."""
    if proto_root is None:
        imageable = UsdGeom.Imageable(prim)
        if imageable.ComputeVisibility(time) == UsdGeom.Tokens.invisible:
            return "invisible"
        purpose = imageable.ComputePurpose()
    else:
        purpose, q = UsdGeom.Tokens.default_, prim
        while q:
            visibility = q.GetAttribute(UsdGeom.Tokens.visibility)
            if visibility and visibility.Get(time) == UsdGeom.Tokens.invisible:
                return "invisible"
            attr = q.GetAttribute(UsdGeom.Tokens.purpose)
            if purpose == UsdGeom.Tokens.default_ and attr and attr.HasAuthoredValue():
                purpose = attr.Get()
            if q == proto_root:
                break
            q = q.GetParent()
    if purpose in (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy):
        return f"purpose {purpose}"
    if prim.IsA(UsdGeom.Mesh):
        faces = _all_holes(UsdGeom.Mesh(prim), time)
        if faces:
            return f"every face is a hole: holeIndices lists all {faces} faces"
    return None


def _all_holes(mesh: UsdGeom.Mesh, time: Usd.TimeCode) -> int:
    """The number of faces of ``mesh`` when its ``holeIndices`` list every one of them (at least one), else 0
    (indices out of range are :class:`_Topology`'s to report)."""
    raw_holes = mesh.GetHoleIndicesAttr().Get(time)
    if raw_holes is None or len(raw_holes) == 0:
        return 0
    counts = mesh.GetFaceVertexCountsAttr().Get(time)
    n = 0 if counts is None else len(counts)
    holes = np.asarray(raw_holes, dtype=np.int64)
    if n == 0 or holes.min() < 0 or holes.max() >= n:
        return 0
    return n if np.unique(holes).shape[0] == n else 0


def _composition_errors(stage: Usd.Stage, root: Sdf.Path) -> list[str]:
    """The stage's composition errors that can leave meshes out of a load of ``root``'s subtree, sorted: not
    those of a deactivated prim (or one under it: not on the stage, how a broken reference is switched off)
    nor those of prims outside ``root``'s subtree and its ancestors (which bring opinions into it)."""
    out = []
    for err in stage.GetCompositionErrors():
        site_path = getattr(getattr(err, "rootSite", None), "path", None)
        if site_path is None or site_path.isEmpty:  # (no site to tell: it counts)
            out.append(("", str(err)))
            continue
        site = site_path.StripAllVariantSelections()
        if site != Sdf.Path.absoluteRootPath:  # (a sublayer's error is the pseudo-root's)
            site = site.GetPrimPath()  # (a property's error: its prim's)
        if not (site.HasPrefix(root) or root.HasPrefix(site)):
            continue
        if site != Sdf.Path.absoluteRootPath:
            prim = stage.GetPrimAtPath(site)
            if not prim or not prim.IsActive():
                continue
        out.append((str(site), str(err)))
    return [message for _, message in sorted(out)]


def _declared_triangles(prim: Usd.Prim, time: Usd.TimeCode) -> int:
    """The triangles of the Mesh ``prim``'s faces (a face of n >= 3 corners: n - 2), from its
    ``faceVertexCounts`` alone (its points not read)."""
    counts = UsdGeom.Mesh(prim).GetFaceVertexCountsAttr().Get(time)
    if counts is None or len(counts) == 0:
        return 0
    n = np.asarray(counts, dtype=np.int64)
    return int(np.maximum(n - 2, 0).sum())


def _declared_total(drawn: list[tuple[Usd.Prim, Gf.Matrix4d, Usd.Prim | None]], time: Usd.TimeCode) -> int:
    """The triangles the ``drawn`` meshes (:func:`_drawn_meshes`') declare (:func:`_declared_triangles`), each
    instance counted, those not rendered not (each mesh's counts read once)."""
    declared: dict[tuple[Sdf.Path, Sdf.Path | None], int] = {}
    for prim, _, proto_root in drawn:
        key = (prim.GetPath(), None if proto_root is None else proto_root.GetPath())
        if key not in declared:
            unseen = _not_rendered(prim, time, proto_root) is None
            declared[key] = _declared_triangles(prim, time) if unseen else 0
    return sum(declared[(q.GetPath(), None if r is None else r.GetPath())] for q, _, r in drawn)


def declared_triangle_count(path: Path, prim_path: str | None = None) -> int | None:
    """The triangles the USD stage at ``path`` (under ``prim_path``) declares, as ``max_triangles`` counts
    them before any points are read (:func:`load_usd`): from the ``faceVertexCounts`` of every drawn mesh,
    each instance counted. None when the stage does not open whole (the load says why)."""
    from ..usd.probe import checked

    try:
        with checked(path) as probed:
            if probed is not None:
                return None
            stage = Usd.Stage.Open(str(path))
            if stage is None:
                return None
            root = stage.GetPseudoRoot() if prim_path is None else stage.GetPrimAtPath(prim_path)
            if not root or not root.IsValid() or _composition_errors(stage, root.GetPath()):
                return None
            time = Usd.TimeCode.EarliestTime()
            xf_cache = UsdGeom.XformCache(time)
            predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
            drawn = list(_drawn_meshes(root, predicate, xf_cache.GetLocalToWorldTransform, xf_cache, time))
            return _declared_total(drawn, time)
    except Exception:  # noqa: BLE001 - no count: the load reports the problem
        return None


def load_usd(path: Path, prim_path: str | None = None, *, max_triangles: int | None = None) -> Mesh:
    """Load every Mesh prim of a USD stage (or those under ``prim_path``) as one cleaned mesh
    (``max_triangles``: see :func:`swpm_usd.io.load_mesh`; counted from ``faceVertexCounts`` of every drawn
    mesh, each instance counted, before any points are read).

    A crate file (``.usdc``) is opened first in a probe process (:func:`swpm_usd.usd.probe.check`): one that
    crashes usd-core there, hangs it or makes it fail is a :class:`MeshLoadError` with what the probe found,
    without being opened in this process."""
    from ..usd.probe import checked

    # (the text layers the check parsed here are held while the stage opens: each parsed once)
    with checked(path) as probed:
        if probed is not None:
            raise MeshLoadError(path, probed.message.removeprefix(f"{path}: "))
        try:
            try:
                stage = Usd.Stage.Open(str(path))
            except Tf.ErrorException as e:
                raise MeshLoadError(path, f"USD could not open it: {tf_message(e)}") from e
            if stage is None:
                raise MeshLoadError(path, "USD could not open it")
            if prim_path is None:
                root = stage.GetPseudoRoot()
            else:
                if not Sdf.Path.IsValidPathString(prim_path) or not Sdf.Path(prim_path).IsAbsolutePath():
                    raise MeshLoadError(
                        path,
                        f"prim_path {prim_path!r} is not an absolute USD prim path",
                        code="PARAMETER_INVALID",
                    )
                root = stage.GetPrimAtPath(prim_path)
                if not root or not root.IsValid():
                    raise MeshLoadError(path, f"no prim at {prim_path}", code="PARAMETER_INVALID")
            # a sublayer or reference that does not resolve: its meshes would be missing from the build
            errors = _composition_errors(stage, root.GetPath())
            if errors:
                what = "1 composition error" if len(errors) == 1 else f"{len(errors)} composition errors"
                raise MeshLoadError(
                    path, f"{what}, the stage is incomplete; first: {errors[0]}", code="INPUT_INCOMPLETE"
                )
            time = Usd.TimeCode.EarliestTime()
            xf_cache = UsdGeom.XformCache(time)
            parts: list[Part] = []
            n_mesh_prims = 0
            unrendered: list[str] = []
            predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
            # (a prototype's mesh, drawn at each of an instancer's instances, is read once)
            local: dict[tuple[Sdf.Path, Sdf.Path | None], tuple[str | None, Part | None]] = {}
            drawn: Iterable[tuple[Usd.Prim, Gf.Matrix4d, Usd.Prim | None]] = _drawn_meshes(
                root, predicate, xf_cache.GetLocalToWorldTransform, xf_cache, time
            )
            if max_triangles is not None:
                drawn = list(drawn)
                how = " (declared by the faceVertexCounts of the meshes drawn, each instance counted)"
                over_budget(path, _declared_total(drawn, time), max_triangles, how)
            for prim, to_world, proto_root in drawn:
                n_mesh_prims += 1
                key = (prim.GetPath(), None if proto_root is None else proto_root.GetPath())
                if key not in local:
                    why = _not_rendered(prim, time, proto_root)
                    local[key] = (why, None if why is not None else _read_mesh(prim, time))
                why, part = local[key]
                if why is not None:
                    unrendered.append(f"{prim.GetPath()} ({why})")
                elif part is not None:
                    # (USD matrices act on row vectors; transform_part wants the column-vector form)
                    parts.append(transform_part(part, np.array(to_world, dtype=np.float64).T))
        except MeshLoadError:
            raise
        except _Invalid as e:
            raise MeshLoadError(path, str(e)) from e
        except Tf.ErrorException as e:
            raise MeshLoadError(path, f"USD error: {tf_message(e)}") from e
        except Exception as e:
            raise MeshLoadError(path, f"{type(e).__name__}: {e}") from e
    under = "" if prim_path is None else f" under {prim_path}"
    if n_mesh_prims == 0:
        raise MeshLoadError(path, f"no UsdGeom.Mesh prims{under}", code="INPUT_EMPTY")
    if not parts:
        skipped = ""
        if unrendered:
            listed = first_few(unrendered)
            skipped = f"; {len(unrendered)} of them not rendered: {listed}"
        raise MeshLoadError(
            path,
            f"no triangles: the {n_mesh_prims} Mesh prims{under} have no faces (or only holes){skipped}",
            code="INPUT_EMPTY",
        )
    points, triangles, attrs = concatenate_parts(parts, path)
    return clean_mesh(points, triangles, attrs, str(path))
