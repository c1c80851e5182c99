"""A corruption campaign of the mesh loaders: mutated copies of small valid files of every trimesh format
(truncations, byte flips, header edits, bad UTF-8, JSON edits in a .gltf or a .glb's chunk, repeated
chunks), each loaded by ``load_mesh`` in a forked process of its own (address space limited, killed past a
time limit), and the outcomes counted: loaded, refused in our words, refused in trimesh's words ("trimesh
could not read it (...)"), another exception, a crash or a hang; with the most memory and time a mutant took.

    python benchmarks/corrupt_campaign.py [--mutants 3000] [--seed 126] [--show 60] [--out DIR] [--only TEXT]

The seeds are suzanne (967 triangles) and 300 triangles of spot (with vertex colours), written by trimesh
as OBJ, binary and ASCII PLY and STL, OFF, GLB and .gltf (buffers inline), and suzanne's GLB placed at 3
instances by EXT_mesh_gpu_instancing (``--only instanced``: its mutants alone).
"""

from __future__ import annotations

import argparse
import base64
import collections
import json
import os
import pickle
import random
import re
import resource
import signal
import struct
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
MESHES = HERE.parent.parent / "shared" / "meshes"
if not MESHES.is_dir():
    MESHES = Path("/work/shared/meshes")
#: a mutant's limits: address space (bytes), wall time (s)
MEMORY_LIMIT = 4 << 30
TIME_LIMIT = 60.0
EXTREME = [
    b"1e400",
    b"nan",
    b"-inf",
    b"999999999999",
    b"-5",
    b"0",
    b"4294967295",
    b"2147483648",
    b"-1",
    b"3.5",
]
WORDS = [b"float", b"double", b"uchar", b"int", b"list", b"element", b"vertex", b"face", b"ascii"]
WORDS += [b"binary_big_endian", b"property", b"end_header", b"x", b"", b"OFF", b"COFF", b"solid", b"facet"]
BAD_UTF8 = [b"\xff", b"\xfe\xff", b"\xc3(", b"\xe2\x82", b"\xed\xa0\x80", b"\x80abc", b"\xf4\x90\x80\x80"]


def seeds(folder: Path) -> dict[str, bytes]:
    import trimesh

    from swpm_usd.io import load_mesh

    out = {}
    suzanne = load_mesh(MESHES / "suzanne.obj")
    spot = load_mesh(MESHES / "spot.obj")
    keep = np.arange(300)
    used = np.unique(spot.triangles[keep])
    remap = np.full(spot.vertex_count, -1)
    remap[used] = np.arange(used.shape[0])
    colours = (np.abs(spot.points[used]) * 255 / np.abs(spot.points).max()).astype(np.uint8)
    spot_sub = trimesh.Trimesh(spot.points[used], remap[spot.triangles[keep]], process=False)
    spot_sub.visual.vertex_colors = np.column_stack([colours, np.full(len(used), 255, np.uint8)])
    meshes = {"suzanne": trimesh.Trimesh(suzanne.points, suzanne.triangles, process=False), "spot": spot_sub}
    for stem, mesh in meshes.items():
        for kind, ext, kwargs in [
            ("obj", "obj", {}),
            ("ply", "ply", {}),
            ("ply_ascii", "ply", {"encoding": "ascii"}),
            ("stl", "stl", {}),
            ("stl_ascii", "stl", {"file_type": "stl_ascii"}),
            ("off", "off", {}),
            ("glb", "glb", {}),
        ]:
            data = mesh.export(file_type=kwargs.pop("file_type", ext), **kwargs)
            out[f"{stem}_{kind}.{ext}"] = data.encode() if isinstance(data, str) else data
        files = mesh.export(file_type="gltf")
        doc = json.loads(files["model.gltf"])
        for b in doc["buffers"]:
            b["uri"] = "data:application/octet-stream;base64," + base64.b64encode(files[b["uri"]]).decode()
        out[f"{stem}_gltf.gltf"] = json.dumps(doc, indent=1).encode()
    out["suzanne_instanced.glb"] = _instanced(out["suzanne_glb.glb"])
    return out


def _instanced(glb: bytes) -> bytes:
    """The .glb ``glb`` with its mesh node placed at 3 instances (EXT_mesh_gpu_instancing: a float
    TRANSLATION, a normalized short ROTATION, a float SCALE)."""
    text, rest = _glb_parts(glb)
    doc = json.loads(text)
    n = struct.unpack_from("<I", rest)[0]
    binary = bytearray(rest[8 : 8 + n])
    attributes = {}
    for name, values, component in [
        ("TRANSLATION", np.array([[0, 0, 0], [5, 0, 0], [0, 5, 0]], np.float32), 5126),
        ("ROTATION", np.array([[0, 0, 0, 32767], [0, 23170, 0, 23170], [0, 0, 32767, 0]], np.int16), 5122),
        ("SCALE", np.array([[1, 1, 1], [2, 2, 2], [1, -1, 1]], np.float32), 5126),
    ]:
        binary.extend(b"\0" * (-len(binary) % 4))
        doc["bufferViews"].append({"buffer": 0, "byteOffset": len(binary), "byteLength": values.nbytes})
        binary.extend(values.tobytes())
        kind = {3: "VEC3", 4: "VEC4"}[values.shape[1]]
        accessor = {"bufferView": len(doc["bufferViews"]) - 1, "componentType": component, "count": 3}
        normalized = {"normalized": True} if component == 5122 else {}
        doc["accessors"].append(accessor | {"type": kind} | normalized)
        attributes[name] = len(doc["accessors"]) - 1
    binary.extend(b"\0" * (-len(binary) % 4))
    doc["buffers"][0]["byteLength"] = len(binary)
    node = next(node for node in doc["nodes"] if "mesh" in node)
    node["extensions"] = {"EXT_mesh_gpu_instancing": {"attributes": attributes}}
    doc["extensionsUsed"] = ["EXT_mesh_gpu_instancing"]
    return _glb(json.dumps(doc).encode(), struct.pack("<II", len(binary), 0x004E4942) + bytes(binary))


def _glb_parts(data: bytes) -> tuple[bytes, bytes] | None:
    if data[:4] != b"glTF" or len(data) < 20:
        return None
    n = struct.unpack_from("<I", data, 12)[0]
    return data[20 : 20 + n], data[20 + n :]


def _glb(text: bytes, rest: bytes) -> bytes:
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + rest
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def _json_edit(doc: object, rng: random.Random) -> None:
    """One value somewhere in the JSON document replaced by an odd one."""
    paths = []

    def walk(node: object, trail: list) -> None:
        if isinstance(node, dict):
            for k, v in node.items():
                paths.append((node, k))
                walk(v, trail + [k])
        elif isinstance(node, list):
            for i, v in enumerate(node):
                paths.append((node, i))
                walk(v, trail + [i])

    walk(doc, [])
    if not paths:
        return
    parent, key = rng.choice(paths)
    odd = [-1, 0, 2**40, 1e300, "x", None, [], {}, True, 3.5, [1, 2], 2**31, 5, 1]
    if rng.random() < 0.15 and isinstance(parent, dict):
        del parent[key]
    else:
        parent[key] = rng.choice(odd)


def mutate(name: str, data: bytes, rng: random.Random) -> tuple[str, bytes]:
    """(what was done, the mutant)."""
    kind = rng.choice(["truncate", "flip", "header", "utf8", "json", "repeat", "number"])
    if kind == "json" and not name.endswith((".glb", ".gltf")):
        kind = "header"
    n = len(data)
    if kind == "truncate":
        i = rng.randrange(n)
        return f"truncate@{i}", data[:i]
    if kind == "flip":
        out = bytearray(data)
        where = []
        for _ in range(rng.randint(1, 8)):
            i = rng.randrange(n) if rng.random() < 0.5 else rng.randrange(min(n, 512))
            out[i] ^= rng.randrange(1, 256)
            where.append(i)
        return f"flip@{where}", bytes(out)
    if kind == "utf8":
        i = rng.randrange(min(n, 600)) if rng.random() < 0.7 else rng.randrange(n)
        return f"utf8@{i}", data[:i] + rng.choice(BAD_UTF8) + data[i:]
    if kind == "repeat":
        i = rng.randrange(n)
        j = min(n, i + rng.randint(1, 400))
        return f"repeat@{i}:{j}", data[:j] + data[i:j] * rng.randint(1, 5) + data[j:]
    if kind == "number":
        numbers = list(re.finditer(rb"-?\d+(\.\d+)?(e-?\d+)?", data[: 4096 if rng.random() < 0.6 else n]))
        if not numbers:
            return "none", data
        m = rng.choice(numbers)
        return f"number@{m.start()}", data[: m.start()] + rng.choice(EXTREME) + data[m.end() :]
    if kind == "json":
        parts = _glb_parts(data) if name.endswith(".glb") else (data, b"")
        if parts is None:
            return "none", data
        text, rest = parts
        if rng.random() < 0.5:  # (the JSON text itself: a byte changed, lengths kept)
            out = bytearray(text)
            i = rng.randrange(len(out))
            out[i] = rng.choice(b'{}[]",:0a\xff \\')
            text = bytes(out)
            what = f"json-byte@{i}"
        else:
            doc = json.loads(text)
            _json_edit(doc, rng)
            text = json.dumps(doc).encode()
            what = "json-value"
        return what, (_glb(text, rest) if name.endswith(".glb") else text)
    # header: a word or a line of the first lines changed
    head_end = data.find(b"end_header")
    head_end = head_end + 10 if head_end > 0 else min(n, 300)
    head, body = data[:head_end], data[head_end:]
    lines = head.split(b"\n")
    i = rng.randrange(len(lines))
    words = lines[i].split(b" ")
    choice = rng.random()
    if choice < 0.3:
        lines.pop(i)
    elif choice < 0.5:
        lines.insert(i, lines[i])
    else:
        words[rng.randrange(len(words))] = rng.choice(WORDS + EXTREME)
        lines[i] = b" ".join(words)
    return f"header@line{i + 1}", b"\n".join(lines) + body


def run_one(path: Path) -> tuple[str, str, float, int]:
    """(outcome, message, seconds, max RSS KiB) of loading ``path`` in a forked child."""
    read, write = os.pipe()
    start = time.perf_counter()
    pid = os.fork()
    if pid == 0:  # the child
        os.close(read)
        try:
            resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
            import warnings

            warnings.simplefilter("ignore")
            from swpm_usd.errors import MeshLoadError
            from swpm_usd.io import load_mesh

            try:
                mesh = load_mesh(path)
                result = ("loaded", f"{mesh.triangle_count} triangles")
            except MeshLoadError as e:
                words = "trimesh" if "trimesh could not read it" in e.problem else "ours"
                result = (words, e.problem if e.path == str(path) else f"PATH NOT NAMED: {e}")
            except MemoryError as e:
                result = ("memory", repr(e)[:300])
            except BaseException as e:  # noqa: BLE001
                result = ("exception", f"{type(e).__name__}: {e}"[:300])
            os.write(write, pickle.dumps(result))
        finally:
            os._exit(0)
    os.close(write)
    chunks = []
    os.set_blocking(read, False)
    status = rusage = None
    while True:
        try:
            chunk = os.read(read, 1 << 16)
            if chunk:
                chunks.append(chunk)
        except BlockingIOError:
            pass
        done, status, rusage = os.wait4(pid, os.WNOHANG)
        if done:
            break
        if time.perf_counter() - start > TIME_LIMIT:
            os.kill(pid, signal.SIGKILL)
            _, status, rusage = os.wait4(pid, 0)
            os.close(read)
            return "hang", f"killed after {TIME_LIMIT} s", time.perf_counter() - start, rusage.ru_maxrss
        time.sleep(0.002)
    while True:
        try:
            chunk = os.read(read, 1 << 16)
        except BlockingIOError:
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(read)
    seconds = time.perf_counter() - start
    if not chunks:
        return "crash", f"exit status {status}", seconds, rusage.ru_maxrss
    outcome, message = pickle.loads(b"".join(chunks))
    return outcome, message, seconds, rusage.ru_maxrss


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mutants", type=int, default=3000)
    parser.add_argument("--seed", type=int, default=126)
    parser.add_argument("--show", type=int, default=60, help="messages in trimesh's words (and worse) shown")
    parser.add_argument("--out", type=Path, default=None, help="keep the mutants worth a look here")
    parser.add_argument("--only", default="", help="only the seeds whose name holds this")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory(prefix="campaign-") as tmp:
        run(args, Path(tmp))


def run(args: argparse.Namespace, folder: Path) -> None:
    from swpm_usd.io import load_mesh

    base = seeds(folder)
    for name, data in base.items():  # (warm: the modules each load needs are imported before forking)
        (folder / name).write_bytes(data)
        load_mesh(folder / name)
    rng = random.Random(args.seed)
    counts: collections.Counter = collections.Counter()
    worst_rss = worst_time = (0, "")
    shown = []
    names = sorted(name for name in base if args.only in name)
    for k in range(args.mutants):
        name = names[k % len(names)]
        what, data = mutate(name, base[name], rng)
        path = folder / f"m{k}{Path(name).suffix}"
        path.write_bytes(data)
        outcome, message, seconds, rss = run_one(path)
        counts[outcome] += 1
        worst_rss = max(worst_rss, (rss, f"{name} {what}"))
        worst_time = max(worst_time, (seconds, f"{name} {what}"))
        if outcome not in ("loaded", "ours") or "PATH NOT NAMED" in message:
            shown.append(f"{outcome}: {name} {what}: {message[:200]}")
            if args.out is not None:
                args.out.mkdir(parents=True, exist_ok=True)
                (args.out / f"{outcome}-m{k}-{name}").write_bytes(data)
        path.unlink()
    for line in shown[: args.show]:
        print(line)
    print(
        f"mutants {args.mutants} seed {args.seed}: "
        + ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))
    )
    print(f"max RSS {worst_rss[0] / 1024:.0f} MiB ({worst_rss[1]})")
    print(f"max time {worst_time[0]:.2f} s ({worst_time[1]})")


if __name__ == "__main__":
    main()
