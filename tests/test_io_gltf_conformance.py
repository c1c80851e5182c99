"""glTF 2.0 conformance of the loader for what changes the triangles drawn: a buffer's uri is a
percent-encoded relative URI (its file found by the decoded name, never outside the .gltf's folder), and a
primitive without POSITION is not drawn (the others are). The files are written here (numpy and json), as
in test_io_instancing.py."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from test_io_instancing import FACES, POINTS, Builder
from trimesh import transformations as tf

from swpm_usd.errors import MeshLoadError
from swpm_usd.io import load_mesh
from swpm_usd.mesh import Mesh
from swpm_usd.pipeline.assets import _gltf_buffers


def _tetrahedron(b: Builder, *, offset: float = 0.0) -> dict:
    """A primitive of the tetrahedron (moved by ``offset`` along x)."""
    points = POINTS + np.float32([offset, 0, 0])
    pos = b.accessor(points, "VEC3", 5126, min=points.min(0).tolist(), max=points.max(0).tolist())
    return {"attributes": {"POSITION": pos}, "indices": b.accessor(FACES.reshape(-1), "SCALAR", 5123)}


def _placed(b: Builder, *primitives: dict) -> Builder:
    b.doc["meshes"].append({"primitives": list(primitives)})
    b.doc["nodes"].append({"mesh": len(b.doc["meshes"]) - 1})
    b.doc["scenes"][0]["nodes"].append(len(b.doc["nodes"]) - 1)
    return b


def _with_buffer_file(tmp_path: Path, b: Builder, file_name: str, uri: str) -> Path:
    """``b`` written as a .gltf whose buffer is the file ``file_name`` beside it, named by ``uri``."""
    b.blob.extend(b"\0" * (-len(b.blob) % 4))
    (tmp_path / file_name).write_bytes(bytes(b.blob))
    doc = json.loads(json.dumps(b.doc))
    doc["buffers"][0].update(byteLength=len(b.blob), uri=uri)
    path = tmp_path / "model.gltf"
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize(
    ("file_name", "uri"),
    [
        ("my mesh.bin", "my%20mesh.bin"),
        ("maillage é.bin", "maillage%20%C3%A9.bin"),
        ("data/a b.bin", "data/a%20b.bin"),
        ("100%.bin", "100%.bin"),  # (not a valid escape: the name as written, as before)
    ],
)
def test_a_buffer_uri_is_percent_decoded(tmp_path: Path, file_name: str, uri: str) -> None:
    (tmp_path / "data").mkdir()
    b = _placed(b := Builder(), _tetrahedron(b))
    path = _with_buffer_file(tmp_path, b, file_name, uri)
    mesh = load_mesh(path)
    assert np.array_equal(np.unique(mesh.points, axis=0), np.unique(POINTS, axis=0))
    assert mesh.triangles.shape == (4, 3)
    # the pipeline hashes the file the loader reads (a change to it rebuilds the asset)
    assert _gltf_buffers(path) == [tmp_path / file_name]


def test_the_decoded_name_is_read_before_the_name_as_written(tmp_path: Path) -> None:
    b = _placed(b := Builder(), _tetrahedron(b, offset=5.0))
    path = _with_buffer_file(tmp_path, b, "a b.bin", "a%20b.bin")
    decoy = _placed(d := Builder(), _tetrahedron(d))
    decoy.blob.extend(b"\0" * (-len(decoy.blob) % 4))
    (tmp_path / "a%20b.bin").write_bytes(bytes(decoy.blob))
    assert load_mesh(path).points[:, 0].min() == 5.0


def test_a_decoded_uri_does_not_lead_out_of_the_folder(tmp_path: Path) -> None:
    """``%2e%2e/`` is ``../``: the file above the .gltf's folder is not read (the loader looks inside the
    folder alone), and one by that last name inside the folder is, as for a uri written ``../``."""
    inner = tmp_path / "inner"
    inner.mkdir()
    b = _placed(b := Builder(), _tetrahedron(b))
    path = _with_buffer_file(tmp_path, b, "secret.bin", "%2e%2e/secret.bin")
    moved = inner / "model.gltf"
    path.rename(moved)
    with pytest.raises(MeshLoadError, match="secret.bin"):
        load_mesh(moved)
    (inner / "secret.bin").write_bytes((tmp_path / "secret.bin").read_bytes())
    assert load_mesh(moved).triangles.shape == (4, 3)


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_a_primitive_without_position_is_skipped_with_a_warning(tmp_path: Path, suffix: str) -> None:
    b = Builder()
    drawn = _tetrahedron(b)
    _placed(b, drawn, {"attributes": {}, "indices": drawn["indices"]})
    _placed(b, {"attributes": {"NORMAL": drawn["attributes"]["POSITION"]}})
    with pytest.warns(
        UserWarning, match=r"meshes\[0\]\.primitives\[1\], meshes\[1\]\.primitives\[0\] without"
    ):
        mesh = load_mesh(b.write(tmp_path / f"m{suffix}"))
    assert mesh.triangles.shape == (4, 3)
    assert np.array_equal(np.unique(mesh.points, axis=0), np.unique(POINTS, axis=0))


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_a_file_of_primitives_without_position_alone_has_no_triangles(tmp_path: Path, suffix: str) -> None:
    b = Builder()
    _placed(b, {"attributes": {}, "indices": _tetrahedron(b)["indices"]})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(MeshLoadError, match="no triangles"):
            load_mesh(b.write(tmp_path / f"m{suffix}"))


#: a morph target's displacements of the tetrahedron's points (and of its normals, along +x)
MOVE = np.array([[0, 0, 10], [0, 0, 0], [0, 2, 0], [1, 1, 1]], np.float32)


def _morph(b: Builder, normals: bool = False) -> dict:
    """The tetrahedron's primitive with one morph target (MOVE; normals all +z, moved along +x)."""
    p = _tetrahedron(b)
    p["targets"] = [{"POSITION": b.accessor(MOVE, "VEC3", 5126, min=[0, 0, 0], max=[1, 2, 10])}]
    if normals:
        p["attributes"]["NORMAL"] = b.accessor(np.tile(np.float32([0, 0, 1]), (4, 1)), "VEC3", 5126)
        p["targets"][0]["NORMAL"] = b.accessor(np.tile(np.float32([1, 0, 0]), (4, 1)), "VEC3", 5126)
    return p


def _point_set(points: np.ndarray) -> np.ndarray:
    return np.unique(np.round(points.astype(np.float64), 5), axis=0)


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_a_mesh_is_drawn_at_its_default_morph_weights(tmp_path: Path, suffix: str) -> None:
    """glTF 2.0: the rendered POSITION is POSITION + sum(weights[i] * targets[i].POSITION), the mesh's
    ``weights`` being the default; NORMAL likewise."""
    b = Builder()
    _placed(b, _morph(b, normals=True))
    b.doc["meshes"][0]["weights"] = [0.5]
    mesh = load_mesh(b.write(tmp_path / f"m{suffix}"))
    assert np.array_equal(_point_set(mesh.points), _point_set(POINTS + 0.5 * MOVE))
    expected = np.float32([0.5, 0, 1]) / np.linalg.norm([0.5, 0, 1])
    assert np.allclose(mesh.attributes["normal"], expected, atol=1e-6)


def test_a_node_s_morph_weights_override_its_mesh_s(tmp_path: Path) -> None:
    """Two nodes of one mesh: one with its own weights (drawn at them), one without (the mesh's: zero when
    the mesh has none), the mesh's own unchanged for it."""
    b = Builder()
    _placed(b, _morph(b))
    b.doc["nodes"][0]["weights"] = [1.0]
    b.doc["nodes"].append({"mesh": 0, "translation": [20.0, 0.0, 0.0]})
    b.doc["scenes"][0]["nodes"].append(1)
    mesh = load_mesh(b.write(tmp_path / "m.gltf"))
    expected = np.concatenate([POINTS + MOVE, POINTS + np.float32([20, 0, 0])])
    assert np.array_equal(_point_set(mesh.points), _point_set(expected))


def test_a_sparse_morph_target_without_a_buffer_view_is_applied(tmp_path: Path) -> None:
    """Exporters write a target that moves few points as zeros with sparse values (no bufferView)."""
    b = Builder()
    p = _tetrahedron(b)
    where, moved = b.view(np.array([2], np.uint16)), b.view(np.float32([[0, 0, -3]]))
    sparse = {
        "count": 1,
        "indices": {"bufferView": where, "componentType": 5123},
        "values": {"bufferView": moved},
    }
    b.doc["accessors"].append({"componentType": 5126, "count": 4, "type": "VEC3", "sparse": sparse})
    p["targets"] = [{"POSITION": len(b.doc["accessors"]) - 1}]
    _placed(b, p)
    b.doc["meshes"][0]["weights"] = [2.0]
    mesh = load_mesh(b.write(tmp_path / "m.gltf"))
    assert np.array_equal(
        _point_set(mesh.points),
        _point_set(POINTS + np.float32([[0, 0, 0], [0, 0, 0], [0, 0, -6], [0, 0, 0]])),
    )


@pytest.mark.parametrize(
    ("weights", "problem"),
    [
        (["a"], "morph weights .* are not all finite numbers"),
        ([1.0], "morph target's POSITION .* has 3 elements"),
    ],
)
def test_bad_morph_weights_or_targets_are_named(tmp_path: Path, weights: list, problem: str) -> None:
    b = Builder()
    p = _morph(b)
    short = b.accessor(MOVE[:3], "VEC3", 5126)
    if weights == [1.0]:
        p["targets"][0]["POSITION"] = short
    _placed(b, p)
    b.doc["meshes"][0]["weights"] = weights
    with pytest.raises(MeshLoadError, match=problem):
        load_mesh(b.write(tmp_path / "m.gltf"))


def _skinned(b: Builder, joints: np.ndarray, weights: np.ndarray) -> None:
    """The tetrahedron skinned by two joints: node 1 (the root joint, at 2 0 0) and its child node 2 (at
    0 1 0 from it, turned 90 degrees about z, bound where it would be unturned); the skinned node 0 has a
    transform of its own, which glTF 2.0 says is ignored."""
    p = _tetrahedron(b)
    p["attributes"]["JOINTS_0"] = b.accessor(joints.astype(np.uint8), "VEC4", 5121)
    p["attributes"]["WEIGHTS_0"] = b.accessor(weights.astype(np.float32), "VEC4", 5126)
    bind = np.stack([tf.translation_matrix([2, 0, 0]), tf.translation_matrix([2, 1, 0])])
    inverse_bind = np.linalg.inv(bind).transpose(0, 2, 1).reshape(2, 16).astype(np.float32)  # (column-major)
    _placed(b, p)
    b.doc["nodes"][0].update(skin=0, translation=[100.0, 0.0, 0.0])
    b.doc["skins"] = [{"joints": [1, 2], "inverseBindMatrices": b.accessor(inverse_bind, "MAT4", 5126)}]
    b.doc["nodes"] += [
        {"translation": [2.0, 0.0, 0.0], "children": [2]},
        {"translation": [0.0, 1.0, 0.0], "rotation": [0.0, 0.0, float(np.sqrt(0.5)), float(np.sqrt(0.5))]},
    ]
    b.doc["scenes"][0]["nodes"].append(1)


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_a_skinned_mesh_is_drawn_at_its_joints_pose_not_its_node_transform(
    tmp_path: Path, suffix: str
) -> None:
    """glTF 2.0: a skinned vertex is sum(weight_k * joint_k's world x its inverse bind matrix) x POSITION,
    and the skinned node's own transform is ignored. Points 0 and 1 follow the root joint (at its bind
    pose: unmoved), point 3 the turned joint, point 2 half each."""
    joints = np.array([[0, 0, 0, 0], [0, 0, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0]])
    weights = np.array([[1, 0, 0, 0], [1, 0, 0, 0], [0.5, 0.5, 0, 0], [1, 0, 0, 0]])
    b = Builder()
    _skinned(b, joints, weights)
    mesh = load_mesh(b.write(tmp_path / f"m{suffix}"))
    turned = tf.translation_matrix([2, 1, 0]) @ tf.rotation_matrix(np.pi / 2, [0, 0, 1])
    turned = turned @ np.linalg.inv(tf.translation_matrix([2, 1, 0]))
    moved = [np.eye(4), np.eye(4), 0.5 * np.eye(4) + 0.5 * turned, turned]
    expected = np.array([(m @ np.append(v, 1.0))[:3] for m, v in zip(moved, POINTS, strict=True)])
    assert np.array_equal(_point_set(mesh.points), _point_set(expected))


def test_a_skinned_vertex_of_a_joint_the_skin_lacks_is_named(tmp_path: Path) -> None:
    b = Builder()
    _skinned(b, np.array([[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [5, 0, 0, 0]]), np.eye(4)[[0, 0, 0, 0]])
    with pytest.raises(MeshLoadError, match=r"JOINTS_0 names joint 5 of skins\[0\]'s 2"):
        load_mesh(b.write(tmp_path / "m.gltf"))


def test_a_skinned_mesh_at_its_bind_pose_loads_as_its_plain_mesh(tmp_path: Path) -> None:
    """The exporters' usual file: the joints where they were bound, the skinned node's transform the
    skeleton's; the same arrays as the mesh without its skin, to the bit."""
    b = Builder()
    _skinned(b, np.zeros((4, 4)), np.eye(4)[[0, 0, 0, 0]])
    b.doc["nodes"][2].pop("rotation")
    b.doc["nodes"][0]["translation"] = [0.0, 0.0, 0.0]
    skinned = load_mesh(b.write(tmp_path / "skinned.gltf"))
    del b.doc["nodes"][0]["skin"], b.doc["skins"]
    plain = load_mesh(b.write(tmp_path / "plain.gltf"))
    assert np.array_equal(skinned.points, plain.points)
    assert np.array_equal(skinned.triangles, plain.triangles)


@pytest.mark.parametrize("change", [{"skin": 3}, {"joints": [1, 9]}, {"joints": []}])
def test_a_skin_that_is_not_one_is_named(tmp_path: Path, change: dict) -> None:
    b = Builder()
    _skinned(b, np.zeros((4, 4)), np.eye(4)[[0, 0, 0, 0]])
    if "skin" in change:
        b.doc["nodes"][0]["skin"] = change["skin"]
    else:
        b.doc["skins"][0]["joints"] = change["joints"]
    with pytest.raises(MeshLoadError, match="node 0's skin .* is not a skin of joints that are nodes"):
        load_mesh(b.write(tmp_path / "m.gltf"))


def _skinned_points(tmp_path: Path, weights: np.ndarray, **node: object) -> np.ndarray:
    """The points of _skinned's tetrahedron (points 0 and 1 on the root joint, 2 half each, 3 on the turned
    joint) loaded with the weights ``weights``, its skinned node given ``node``'s properties."""
    joints = np.array([[0, 0, 0, 0], [0, 0, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0]])
    b = Builder()
    _skinned(b, joints, weights)
    b.doc["nodes"][0].update(node)
    return _point_set(load_mesh(b.write(tmp_path / "m.gltf")).points)


_WEIGHTS = np.array([[1, 0, 0, 0], [1, 0, 0, 0], [0.5, 0.5, 0, 0], [1, 0, 0, 0]], np.float64)


@pytest.mark.parametrize("last", [[0.5, 0, 0, 0], [0.0, 0, 0, 0], [2.0, 0, 0, 0]])
def test_skin_weights_are_drawn_scaled_to_sum_to_one(tmp_path: Path, last: list) -> None:
    """three.js scales each vertex's weights to sum to 1 (a vertex of none to its first joint at weight 1),
    Blender's armature divides by their sum: point 3 follows its joint, the turned one, whatever its weight.
    Unscaled, 0.5 drew it halfway to the skinned node's origin (which glTF 2.0 ignores) and 0 at it."""
    expected = _skinned_points(tmp_path, _WEIGHTS)
    weights = _WEIGHTS.copy()
    weights[3] = last
    assert np.array_equal(_skinned_points(tmp_path, weights), expected)


def test_a_skinned_node_s_rotation_is_ignored_even_of_a_quaternion_not_of_length_1(tmp_path: Path) -> None:
    """trimesh places the node by its quaternion taken to length 1: the skin's taking the node's transform
    back must use the same, or the node's rotation (0 0 1 1), of length sqrt 2, showed in the points."""
    expected = _skinned_points(tmp_path, _WEIGHTS)
    assert np.array_equal(_skinned_points(tmp_path, _WEIGHTS, rotation=[0.0, 0.0, 1.0, 1.0]), expected)


@pytest.mark.parametrize("accessor", [99, "x", -1])
def test_a_skin_s_inverse_bind_matrices_not_an_accessor_are_named(tmp_path: Path, accessor: object) -> None:
    """Not a silent fallback to trimesh's read, which drew the stored vertices placed by the skinned node."""
    b = Builder()
    _skinned(b, np.zeros((4, 4)), _WEIGHTS)
    b.doc["skins"][0]["inverseBindMatrices"] = accessor
    with pytest.raises(MeshLoadError, match=r"skins\[0\]: its inverseBindMatrices .* is not one of the"):
        load_mesh(b.write(tmp_path / "m.gltf"))


def test_a_folder_of_the_decoded_name_does_not_hide_the_file_named_as_written(tmp_path: Path) -> None:
    """``a%20b.bin`` is looked for as ``a b.bin`` first: a folder of that name is passed over (the pipeline
    hashes files alone), not read as the buffer (IsADirectoryError), and the file ``a%20b.bin`` is read."""
    b = _placed(b := Builder(), _tetrahedron(b))
    path = _with_buffer_file(tmp_path, b, "a%20b.bin", "a%20b.bin")
    (tmp_path / "a b.bin").mkdir()
    mesh = load_mesh(path)
    assert np.array_equal(np.unique(mesh.points, axis=0), np.unique(POINTS, axis=0))
    assert _gltf_buffers(path) == [tmp_path / "a%20b.bin"]


@pytest.mark.parametrize("far", [1000.0, 12345.678])
def test_a_skinned_mesh_bound_far_from_the_origin_at_its_bind_pose_loads_as_its_plain_mesh(
    tmp_path: Path, far: float
) -> None:
    """As an exporter writes a skeleton far out (a scene in centimetres): the skinned node at the origin,
    the inverse bind matrices inv(joint world) in float32, whose translations' rounding grows with the
    distance. At 1000 units the pose was taken for a posed one and drawn to other bits (3e-5 off)."""
    b = Builder()
    _skinned(b, np.zeros((4, 4)), np.eye(4)[[0, 0, 0, 0]])
    turn = np.array([0.1, 0.2, 0.3, 0.9]) / np.linalg.norm([0.1, 0.2, 0.3, 0.9])
    b.doc["nodes"][0]["translation"] = [0.0, 0.0, 0.0]
    b.doc["nodes"][1].update(translation=[far, far / 3, -far / 7], rotation=turn.tolist())
    b.doc["nodes"][2].pop("rotation")
    root = tf.translation_matrix([far, far / 3, -far / 7]) @ tf.quaternion_matrix(turn[[3, 0, 1, 2]])
    bind = np.stack([root, root @ tf.translation_matrix([0, 1, 0])])
    inverse_bind = np.linalg.inv(bind).transpose(0, 2, 1).reshape(2, 16).astype(np.float32)
    b.doc["skins"][0]["inverseBindMatrices"] = b.accessor(inverse_bind, "MAT4", 5126)
    skinned = load_mesh(b.write(tmp_path / "skinned.gltf"))
    del b.doc["nodes"][0]["skin"], b.doc["skins"]
    plain = load_mesh(b.write(tmp_path / "plain.gltf"))
    assert np.array_equal(skinned.points, plain.points)
    assert np.array_equal(skinned.triangles, plain.triangles)


def _mirror_skinned(
    b: Builder,
    points: np.ndarray,
    on_mirror: np.ndarray,
    indices: np.ndarray | None,
    mode: int = 4,
) -> None:
    """A primitive of ``points`` (by ``indices``, or in order) skinned by two joints: node 1, unmoved, and
    node 2, which mirrors x (scale -1 1 1, as a left arm made of a right one); each point on node 2 at
    ``on_mirror``'s weight, on node 1 at the rest; no inverse bind matrices (each the identity). The skinned
    node 0 has no transform of its own."""
    p = {"attributes": {"POSITION": b.accessor(points.astype(np.float32), "VEC3", 5126)}, "mode": mode}
    if indices is not None:
        p["indices"] = b.accessor(indices.astype(np.uint16).reshape(-1), "SCALAR", 5123)
    weights = np.zeros((len(points), 4), np.float32)
    weights[:, 0], weights[:, 1] = 1 - on_mirror, on_mirror
    joints = np.tile(np.uint8([0, 1, 0, 0]), (len(points), 1))
    p["attributes"]["JOINTS_0"] = b.accessor(joints, "VEC4", 5121)
    p["attributes"]["WEIGHTS_0"] = b.accessor(weights, "VEC4", 5126)
    _placed(b, p)
    b.doc["nodes"][0]["skin"] = 0
    b.doc["skins"] = [{"joints": [1, 2]}]
    b.doc["nodes"] += [{}, {"scale": [-1.0, 1.0, 1.0]}]
    b.doc["scenes"][0]["nodes"] += [1, 2]


def _volume(corners: np.ndarray) -> float:
    """The signed volume of a closed surface's triangles ((T, 3, 3) corners): positive when they wind
    counter-clockwise seen from outside (front faces out), as the tetrahedron's FACES do."""
    return float(np.einsum("ti,ti->t", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])).sum() / 6)


#: the tetrahedron's FACES as one TRIANGLE_STRIP (glTF 2.0's triangle i: v_i, v_(i+1+i%2), v_(i+2-i%2))
STRIP = np.array([0, 2, 1, 3, 0, 2])


def _skinned_corners(tmp_path: Path, b: Builder, suffix: str = ".gltf") -> np.ndarray:
    mesh = load_mesh(b.write(tmp_path / f"m{suffix}"))
    return mesh.points[mesh.triangles].astype(np.float64)


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
@pytest.mark.parametrize("layout", ["indexed", "in-order", "strip"])
def test_a_mesh_skinned_by_a_mirroring_joint_keeps_its_front_faces_out(
    tmp_path: Path, suffix: str, layout: str
) -> None:
    """glTF 2.0: a transform of negative determinant reverses the winding, so front faces stay front; for a
    skinned mesh the joints' transforms stand for the skinned node's, which is ignored. The tetrahedron on
    the mirroring joint is drawn mirrored with its faces out (positive volume): the loader flipped by the
    skinned node's transform alone, and drew it inside out."""
    if layout == "indexed":
        points, indices, mode = POINTS, FACES, 4
    elif layout == "in-order":  # (no indices: each triangle's corners in order)
        points, indices, mode = POINTS[FACES.reshape(-1)], None, 4
    else:
        points, indices, mode = POINTS, STRIP, 5
    b = Builder()
    _mirror_skinned(b, points, np.ones(len(points)), indices, mode)
    corners = _skinned_corners(tmp_path, b, suffix)
    assert _point_set(corners.reshape(-1, 3)).tolist() == _point_set(POINTS * [-1, 1, 1]).tolist()
    assert len(corners) == 4 and _volume(corners) == pytest.approx(1 / 6)


def test_mirrored_and_unmirrored_joints_of_one_primitive_each_keep_their_faces_out(tmp_path: Path) -> None:
    """The winding is decided per triangle: one primitive of two tetrahedra (at x 5..6), one on the plain
    joint, one on the mirroring joint (drawn at x -6..-5); both with their faces out."""
    points = np.concatenate([POINTS + [5, 0, 0], POINTS + [5, 0, 0]])
    b = Builder()
    _mirror_skinned(b, points, np.repeat([0.0, 1.0], 4), np.concatenate([FACES, FACES + 4]))
    corners = _skinned_corners(tmp_path, b)
    mirrored = corners.mean(axis=1)[:, 0] < 0
    assert mirrored.sum() == 4 and len(corners) == 8
    assert _volume(corners[mirrored]) == pytest.approx(1 / 6)
    assert _volume(corners[~mirrored]) == pytest.approx(1 / 6)


def test_a_mirrored_skinned_node_does_not_flip_what_its_joints_do_not_mirror(tmp_path: Path) -> None:
    """The skinned node's own transform (here a mirror) is ignored, for the winding too: its joints place
    the tetrahedron unmirrored, faces out. The loader flipped it by the node's mirror: inside out."""
    b = Builder()
    _mirror_skinned(b, POINTS, np.zeros(4), FACES)
    b.doc["nodes"][0]["scale"] = [1.0, -1.0, 1.0]
    corners = _skinned_corners(tmp_path, b)
    assert _point_set(corners.reshape(-1, 3)).tolist() == _point_set(POINTS).tolist()
    assert _volume(corners) == pytest.approx(1 / 6)


@pytest.mark.parametrize(("on_mirror", "flipped"), [(0.4, True), (0.0, False)])
def test_a_triangle_of_mixed_joints_winds_as_the_blend_at_its_centre(
    tmp_path: Path, on_mirror: float, flipped: bool
) -> None:
    """A triangle whose corners blend mirrored and unmirrored joints follows the sign of the determinant of
    the skin's blend at its centre (the mean of its corners' blends, as skinning places the centre): one
    corner wholly on the mirroring joint, two at 0.4 on it (x scaled by 0.2), so the centre's x scale is
    (-1 + 0.2 + 0.2) / 3 < 0 and the triangle is flipped, where its corners' majority would not be; the two
    wholly on the plain joint, (-1 + 1 + 1) / 3 > 0: not flipped, though a corner is on the mirror."""
    points = np.array([[1, 0, 0], [1, 1, 0], [1, 0, 1]], np.float32)
    b = Builder()
    _mirror_skinned(b, points, np.array([1.0, on_mirror, on_mirror]), np.array([[0, 1, 2]]))
    corners = _skinned_corners(tmp_path, b)
    assert len(corners) == 1
    x = 1 - 2 * on_mirror
    posed = np.float64([[-1, 0, 0], [x, 1, 0], [x, 0, 1]])
    np.testing.assert_allclose(np.sort(corners[0], axis=0), np.sort(posed, axis=0), atol=1e-6)
    normal = np.cross(corners[0, 1] - corners[0, 0], corners[0, 2] - corners[0, 0])
    stored = np.cross(posed[1] - posed[0], posed[2] - posed[0])
    assert (np.dot(normal, stored) < 0) == flipped  # (flipped: wound the other way round from the stored)


def test_a_triangle_twisted_by_joints_that_do_not_mirror_keeps_its_stored_winding(tmp_path: Path) -> None:
    """No joint mirrors (each a rotation, det +1), so nothing reverses the winding, as a renderer draws it
    (three.js: by the skinned node's world matrix, here the identity). The triangle's corners are on three
    joints turned half a turn about different axes: the mean of their blends, diag(1, -1, 1) / 3, has a
    negative determinant, and the triangle was reversed as if the skin mirrored it."""
    points = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    b = Builder()
    p = {"attributes": {"POSITION": b.accessor(points, "VEC3", 5126)}}
    p["indices"] = b.accessor(np.uint16([0, 1, 2]), "SCALAR", 5123)
    p["attributes"]["JOINTS_0"] = b.accessor(
        np.uint8([[0, 0, 0, 0], [1, 0, 0, 0], [2, 0, 0, 0]]), "VEC4", 5121
    )
    p["attributes"]["WEIGHTS_0"] = b.accessor(np.float32([[1, 0, 0, 0]] * 3), "VEC4", 5126)
    _placed(b, p)
    b.doc["nodes"][0]["skin"] = 0
    b.doc["skins"] = [{"joints": [1, 2, 3]}]
    b.doc["nodes"] += [{}, {"rotation": [0.0, 0.0, 1.0, 0.0]}, {"rotation": [1.0, 0.0, 0.0, 0.0]}]
    b.doc["scenes"][0]["nodes"] += [1, 2, 3]
    corners = _skinned_corners(tmp_path, b)
    assert len(corners) == 1
    posed = np.float64([[1, 0, 0], [0, -1, 0], [0, 0, -1]])  # (each corner turned by its joint)
    assert _point_set(corners[0]).tolist() == _point_set(posed).tolist()
    normal = np.cross(corners[0, 1] - corners[0, 0], corners[0, 2] - corners[0, 0])
    assert np.dot(normal, np.cross(posed[1] - posed[0], posed[2] - posed[0])) > 0  # (the stored order)


@pytest.mark.parametrize("layout", ["indexed", "strip"])
@pytest.mark.parametrize("on_mirror", [1.0, 0.0])
def test_an_index_past_a_skinned_primitives_vertices_names_its_triangle(
    tmp_path: Path, layout: str, on_mirror: float
) -> None:
    """An index past the vertices of a posed skinned primitive is refused as any primitive's is, naming the
    triangle, the index and the count, whether a joint mirrors it or not (the winding pass had its own, more
    meagre message for a primitive on a mirroring joint)."""
    indices = FACES.copy() if layout == "indexed" else STRIP.copy()
    indices.reshape(-1)[0] = 99
    b = Builder()
    _mirror_skinned(b, POINTS, np.full(4, on_mirror), indices, 4 if layout == "indexed" else 5)
    b.doc["nodes"][2]["rotation"] = [0.0, 0.0, 0.5**0.5, 0.5**0.5]  # (posed, whether it mirrors or not)
    path = b.write(tmp_path / "m.gltf")
    with pytest.raises(
        MeshLoadError, match=r"triangle 0 has vertex index 99 out of range for 4 vertices"
    ) as e:
        load_mesh(path)
    assert e.value.path == str(path) and e.value.code == "INPUT_MALFORMED"


def test_a_skin_s_inverse_bind_matrices_of_another_type_are_named_as_gltf_names_them(tmp_path: Path) -> None:
    """The accessor's type and componentType as glTF 2.0 names them, with the number the file holds (it
    said "not MAT4 of float", what it was left out)."""
    b = Builder()
    _skinned(b, np.zeros((4, 4)), _WEIGHTS)
    b.doc["skins"][0]["inverseBindMatrices"] = b.accessor(np.zeros((8, 4), np.uint16), "VEC4", 5123)
    with pytest.raises(MeshLoadError) as e:
        load_mesh(b.write(tmp_path / "m.gltf"))
    assert str(tmp_path / "m.gltf") in str(e.value)
    assert (
        "skins[0]: its inverseBindMatrices (accessor 5) are VEC4 of UNSIGNED_SHORT (5123), not MAT4 of FLOAT "
        "(5126)" in str(e.value)
    )


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
@pytest.mark.parametrize("value", ["false", 1, 0, None])
def test_normalized_that_is_not_a_boolean_is_refused_naming_the_accessor(
    tmp_path: Path, suffix: str, value: object
) -> None:
    """glTF 2.0's ``normalized`` is a JSON boolean: the string "false" (true as a truth value) read the
    normals as normalized, 0 read them as raw integers; each was a guess, now refused."""
    b = Builder()
    p = _tetrahedron(b)
    normals = np.round(np.eye(4, 3) * 127).astype(np.int8)
    p["attributes"]["NORMAL"] = b.accessor(normals, "VEC3", 5120, normalized=value)
    path = _placed(b, p).write(tmp_path / f"m{suffix}")
    with pytest.raises(MeshLoadError) as e:
        load_mesh(path)
    assert e.value.path == str(path) and e.value.code == "INPUT_MALFORMED"
    assert f"accessor 2 has normalized {value!r}, not true or false" in str(e.value)


#: a triangle slanted to every axis; its front face's normal (counter-clockwise) is (-1, -1, 1) / sqrt(3)
SLANTED = np.array([[0, 0, 0], [1, 0, 1], [0, 1, 1]], np.float32)


def _slanted(b: Builder, scale: list[float], on_joint: float | None) -> None:
    """SLANTED with its face normal at each corner, placed by ``scale``: skinned by two joints (node 1
    unmoved, node 2 scaled by ``scale``; no inverse bind matrices), each corner on node 2 at weight
    ``on_joint`` and on node 1 at the rest; or, ``on_joint`` None, not skinned, its node scaled."""
    normal = np.cross(SLANTED[1] - SLANTED[0], SLANTED[2] - SLANTED[0])
    normals = np.tile(normal / np.linalg.norm(normal), (3, 1)).astype(np.float32)
    attrs = {"POSITION": b.accessor(SLANTED, "VEC3", 5126), "NORMAL": b.accessor(normals, "VEC3", 5126)}
    if on_joint is not None:
        weights = np.zeros((3, 4), np.float32)
        weights[:, 0], weights[:, 1] = 1 - on_joint, on_joint
        attrs["JOINTS_0"] = b.accessor(np.tile(np.uint8([0, 1, 0, 0]), (3, 1)), "VEC4", 5121)
        attrs["WEIGHTS_0"] = b.accessor(weights, "VEC4", 5126)
    _placed(b, {"attributes": attrs})
    if on_joint is None:
        b.doc["nodes"][0]["scale"] = scale
        return
    b.doc["nodes"][0]["skin"] = 0
    b.doc["skins"] = [{"joints": [1, 2]}]
    b.doc["nodes"] += [{}, {"scale": scale}]
    b.doc["scenes"][0]["nodes"] += [1, 2]


@pytest.mark.parametrize(
    "scale", [[1.0, 4.0, 1.0], [-1.0, 4.0, 1.0], [2.0, 0.5, 3.0], [3.0, 3.0, 3.0], [-1.0, 1.0, 1.0]]
)
@pytest.mark.parametrize("on_joint", [1.0, 0.5, None], ids=["skinned", "half-skinned", "node"])
def test_a_normal_stays_perpendicular_to_its_triangle_under_a_non_uniform_scale(
    tmp_path: Path, scale: list[float], on_joint: float | None
) -> None:
    """A normal moves by the inverse transpose of the map that moves its surface: the loaded normal of the
    slanted triangle is its loaded (front) face's, under a node's scale and a joint's. A skinned normal moved
    by the blend itself was tilted off the posed triangle's perpendicular (by 60.5 degrees under (1, 4, 1),
    43-67 under the others not uniform: 7 of these 15 cases failed). Mirrored ((-1, 4, 1)), the triangle
    wound the other way round, the normal still points out of its front face; half on a mirroring joint
    the blend is singular (the triangle flattened onto x = 0) and the normal is the flattened triangle's
    (it was at 90 degrees to it)."""
    b = Builder()
    _slanted(b, scale, on_joint)
    _assert_normals_are_the_face_s(load_mesh(b.write(tmp_path / "slanted.gltf")))


def _assert_normals_are_the_face_s(mesh: Mesh) -> None:
    """``mesh``'s one triangle has its (front) face's normal at each corner."""
    corners = mesh.points[mesh.triangles].astype(np.float64)
    assert len(corners) == 1
    face = np.cross(corners[0, 1] - corners[0, 0], corners[0, 2] - corners[0, 0])
    face /= np.linalg.norm(face)
    normals = mesh.attributes["normal"][mesh.triangles[0]].astype(np.float64)
    np.testing.assert_allclose(normals, np.tile(face, (3, 1)), atol=1e-6)


@pytest.mark.parametrize("scale", [[1.0, 4.0, 1.0], [-1.0, 4.0, 1.0]])
@pytest.mark.parametrize("on_joint", [1.0, 0.5, None], ids=["skinned", "half-skinned", "node"])
def test_a_normal_stays_perpendicular_to_its_triangle_under_a_rotated_non_uniform_scale(
    tmp_path: Path, scale: list[float], on_joint: float | None
) -> None:
    """The scaled joint (or node) also turned 90 degrees about z: its map R S is not symmetric, so its
    inverse transpose (R S^-1, what moves a normal) differs from its inverse (S^-1 R^T). Under the scales
    alone every map was diagonal and the two were the same: a cofactor matrix used transposed (the inverse)
    passed every case of the test above, and fails the skinned ones here."""
    b = Builder()
    _slanted(b, scale, on_joint)
    b.doc["nodes"][-1]["rotation"] = [0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)]  # (the joint; or the node)
    _assert_normals_are_the_face_s(load_mesh(b.write(tmp_path / "slanted.gltf")))


@pytest.mark.parametrize("node_scale", [[1.0, 4.0, 1.0], [-1.0, 4.0, 1.0]])
def test_a_skinned_normal_is_not_moved_by_its_own_node_s_non_uniform_scale(
    tmp_path: Path, node_scale: list[float]
) -> None:
    """The skinned node's own transform is ignored (glTF 2.0), here a non-uniform scale, the joints unmoved:
    the skin's blend, taken back by that transform (S^-1), is not a similarity, and the loader then applies
    the transform to the copy (its normals by S^-T). Each step by its inverse transpose, the normal is the
    unmoved triangle's; by the blend itself it was tilted (S^-2)."""
    b = Builder()
    _slanted(b, [1.0, 1.0, 1.0], 1.0)
    b.doc["nodes"][0]["scale"] = node_scale
    mesh = load_mesh(b.write(tmp_path / "slanted.gltf"))
    np.testing.assert_allclose(mesh.points[mesh.triangles[0]], SLANTED, atol=1e-6)  # (its scale ignored)
    _assert_normals_are_the_face_s(mesh)


def _glb_failing_its_json(b: Builder, path: Path, bin_length: int | None) -> Path:
    """``b`` written as a .glb whose JSON fails a check of the JSON alone (an accessor's ``normalized`` the
    string "false"); ``bin_length``, when given, the length its BIN chunk's header declares (beyond the
    file's end: its bytes were never written)."""
    b.doc["accessors"][0]["normalized"] = "false"
    b.write(path)
    if bin_length is not None:
        data = bytearray(path.read_bytes())
        json_length = int.from_bytes(data[12:16], "little")
        data[20 + json_length : 24 + json_length] = bin_length.to_bytes(4, "little")
        path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize("bin_length", [None, 0xFFFFFFF0], ids=["whole", "declared-beyond-the-file"])
def test_a_glb_s_json_is_checked_before_its_binary_chunk_is_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, bin_length: int | None
) -> None:
    """The checks of a .glb's JSON run on its JSON chunk alone, before the file is read whole: a .glb whose
    JSON fails one is refused for it (naming the accessor) with its BIN chunk unread, whether that chunk is
    there (8 MB here; reading the whole file, or handing it to trimesh, fails this test) or declares 4 GB
    past the file's end, which was refused as a cut chunk before its JSON was looked at."""
    b = Builder()
    b.mesh()
    b.view(np.zeros(2 * 2**20, np.float32))  # (8 MB of binary chunk)
    path = _glb_failing_its_json(b, tmp_path / "m.glb", bin_length)
    real_read_bytes = Path.read_bytes

    def read_bytes(self: Path) -> bytes:
        assert self.name != path.name, "the whole .glb was read"
        return real_read_bytes(self)

    def load_scene(*args: object, **kwargs: object) -> None:
        raise AssertionError("the .glb was handed to trimesh")

    monkeypatch.setattr(Path, "read_bytes", read_bytes)
    monkeypatch.setattr("trimesh.load_scene", load_scene)
    with pytest.raises(MeshLoadError, match="accessor 0 has normalized 'false', not true or false") as e:
        load_mesh(path)
    assert str(e.value.path) == str(path)


def test_a_glb_whose_json_chunk_is_cut_is_refused_for_the_cut_chunk(tmp_path: Path) -> None:
    """The JSON is checked early only when its chunk is whole: a JSON chunk declaring 4 bytes more than follow
    it (its text, whole but for that, parses and fails a check) is refused as the cut chunk it is, as it was
    before the early check (which read what there was of the chunk and reported its JSON)."""
    b = Builder()
    b.mesh()
    path = _glb_failing_its_json(b, tmp_path / "m.glb", None)
    data = bytearray(path.read_bytes())
    json_length = int.from_bytes(data[12:16], "little")
    data = data[: 20 + json_length]  # (the JSON chunk alone, which declares 4 bytes more)
    data[8:12], data[12:16] = len(data).to_bytes(4, "little"), (json_length + 4).to_bytes(4, "little")
    path.write_bytes(bytes(data))
    with pytest.raises(
        MeshLoadError, match=rf"chunk 0 \(JSON\) declares {json_length + 4} bytes, {json_length} "
    ):
        load_mesh(path)


def test_a_glb_chunk_too_long_is_named_by_its_type_not_its_place(tmp_path: Path) -> None:
    """A .glb whose binary chunk comes first (glTF 2.0 puts the JSON first) and declares more bytes than
    follow it: the chunk is named "chunk 0 (binary)"; named by its place, it was "chunk 0 (JSON)"."""
    b = Builder()
    b.mesh()
    path = b.write(tmp_path / "m.glb")
    data = path.read_bytes()
    json_length = int.from_bytes(data[12:16], "little")
    json_chunk, bin_chunk = data[12 : 20 + json_length], bytearray(data[20 + json_length :])
    bin_chunk[:4] = (2**32 - 16).to_bytes(4, "little")
    path.write_bytes(data[:12] + bytes(bin_chunk) + json_chunk)
    with pytest.raises(MeshLoadError, match=r"chunk 0 \(binary\) declares 4294967280 bytes"):
        load_mesh(path)
