"""Pipeline benchmarks: overhead, --jobs scaling and the incremental rerun.

1. Overhead: a run over the shared meshes (--jobs 1); overhead = wall time minus the per-asset work
   (load + build + check + write, as the workers time it), over wall time. Target <= 10 %.
2. Scaling: 20 assets (4 copies each of bunny, dragon-20k, fandisk, bob, nefertiti) with --jobs 1 and
   --jobs 2 (forced rebuilds), each a fresh `swpm-pipeline run` process. Target: jobs 2 >= 1.7x faster.
3. Rerun: 100 small assets built once, then `swpm-pipeline run` again with nothing changed, wall time of
   the whole command (a fresh process). Target <= 2 s.
4. Many assets: 1,000 copies of suzanne (967 triangles, vanilla) built with --jobs 1; overhead as in 1,
   which grows with the asset count if anything per asset costs time in the number of assets. The
   manifest rewritten in full after every asset did, and the planner loading every new asset to count
   its triangles cost 10 of 46 s (overhead 28 %, 3.7 % once the worker matched the rule). Target <= 10 %.
5. Rerun over large inputs: 200 copies of bob.obj (0.94 MB each, 187 MB; vanilla) built once, then a
   rerun with nothing changed, as a fresh `swpm-pipeline run` (wall time) and as `run()` in this process
   (the run's own time), medians of 5 after one settling rerun (inputs written just before the build are
   hashed again once: see inputs._RACY_NS); then the fresh process again with the inputs evicted from the
   page cache before each (posix_fadvise DONTNEED on each file: as on a cold cache or a network mount,
   where the reads cost most). Every rerun hashed every input (187 MB read) before the manifest recorded
   their stat: `run` 0.41 s, now 0.13 s; the command 1.45 s, now 1.15 s; evicted 2.0 s, now 1.3 s
   (medians of 40, alternating with the code before, on a loaded 2-core machine). ``--work DIR`` keeps
   the built project in DIR and reuses it, so the same files can be rerun by another version of the code
   (PYTHONPATH).
6. Rerun of USD files: 200 small glob-matched .usda assets (each referencing a layer of its own) built
   once, then reruns with nothing changed, as `run()` in this process and as a fresh `swpm-pipeline run`
   (medians of 7 after one settling rerun); ``--work DIR`` keeps the project, as in 5.
7. Scene at scale: scene.usda written (as every run with ``scene: true`` writes it, a rerun with nothing to
   build included) for 1,000, 5,000 and 10,000 built assets, each with a USD layer of its own (suzanne,
   vanilla, hard links of one layer), medians of 3. Authored on a stage, each reference was composed as
   it was added, every asset layer opened: 3.4 s at 1,000, 20 s at 5,000; a rerun with nothing changed,
   `swpm-pipeline run --jobs 2` (a fresh process) 22-34 s at 5,000 and 103-118 s at 10,000 (main process
   948 MB), now 4.9-6.2 s and 7.3-8.7 s (506 MB). On the layer alone (Sdf): 0.04 / 0.16 / 0.32 s.
   Target: <= 1 s at 10,000.
8. No-change rerun at 10,000 (``--only rerun-10k``): 10,000 copies of suzanne (vanilla, usd, scene and
   report asked for) built once (5-6 min with --jobs 2), then `swpm-pipeline run --jobs 2` with nothing
   changed, a fresh process (medians of 5 after one settling rerun), what it rewrote, and a cProfile of one.
   Every such rerun serialised and rewrote the 47 MB manifest (2.2 s), scene.usda (0.3 s) and the 11 MB
   report.html (0.45 s), and discovery and the output check resolved every file's folders (1.9 s): 6.5-8.1 s,
   now 2.6-2.9 s (writing nothing; in process 1.9 s: 0.6 reading the manifest, 1.3 planning; 0.5 s of
   imports). A report of 10,000 assets draws its plots on demand: 7.2 MB written in 0.3 s. Since 0.7.1 such
   a rerun imports neither numba nor the encoders (``swpm_usd.encodings``): at 2,000 assets 1.08 -> 0.73 s,
   medians of 5 alternating runs. ``--work DIR`` keeps the built project, as in 5.
9. Scale (``--only scale --assets N ...``, default 500 1000 2000 4000): N small assets of every mesh type
   (OBJ, PLY, STL, GLB, glTF with its own buffer files or embedded, USDA) in nested folders, names with
   spaces and non-ASCII letters, ~3 % byte-for-byte duplicates, ~2 % broken (empty, a PLY that declares
   2e9 vertices, an OBJ indexing a vertex it lacks), four rules (on path and triangles). For each N, fresh
   `swpm-pipeline run --jobs 2` processes: the first run (wall, peak RSS of the largest process), a
   `--dry-run` (the planning alone), a no-change rerun (the broken assets are tried again, as the README
   says: the worker pool starts for them), a rerun after touching 1 % of the inputs (stat moved, bytes
   not: hashed, nothing built) and one after editing 1 % (those rebuilt); the manifest's, report's,
   scene's and `--json` output's sizes. Each grows linearly if nothing costs time in the number of assets.

    python benchmarks/bench_pipeline.py [--out benchmarks/results/pipeline.json] [--only SECTION ...]
        [--work DIR] [--assets N ...]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared" / "meshes"
CLI = [sys.executable, "-m", "swpm_usd.cli"]


def _config(dirpath: Path, extra: str = "") -> Path:
    cfg = dirpath / "pipeline.yaml"
    cfg.write_text(
        "version: 1\nassets: [{glob: 'meshes/*.obj'}]\noutput: {dir: out, report: false}\n"
        "rules:\n  - {name: small, match: {triangles: {max: 15000}}, encoding: skip-strip}\n"
        "  - {name: default, encoding: sliding-window}\n" + extra
    )
    return cfg


def _cli(args: list[str]) -> float:
    """Wall time of ``swpm-pipeline`` with ``args``, a fresh process running the code this one imports: its
    package first on PYTHONPATH, and not started in the project's root (``-m`` puts the working folder
    first on sys.path: a run from the root with PYTHONPATH set to another tree ran the root's code)."""
    import swpm_usd

    root = str(Path(swpm_usd.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p)}
    t = time.perf_counter()
    subprocess.run(CLI + args, check=False, capture_output=True, cwd=HERE, env=env)
    return time.perf_counter() - t


def overhead(work: Path) -> dict:
    from swpm_usd.pipeline import run

    d = work / "overhead"
    (d / "meshes").mkdir(parents=True)
    for p in sorted(SHARED.glob("*.obj")):
        shutil.copy(p, d / "meshes" / p.name)
    cfg = _config(d)
    run(cfg, echo=lambda m: None)  # warm numba caches
    t = time.perf_counter()
    res = run(cfg, force=True, echo=lambda m: None)
    wall = time.perf_counter() - t
    work_s = sum(r["seconds"] for r in res.records.values())
    return {"assets": len(res.records), "wall_s": wall, "asset_work_s": work_s, "overhead": 1 - work_s / wall}


def scaling(work: Path) -> dict:
    d = work / "scaling"
    (d / "meshes").mkdir(parents=True)
    mix = ["stanford-bunny.obj", "dragon-20k.obj", "fandisk.obj", "bob.obj", "nefertiti.obj"]
    for i in range(20):
        src = SHARED / mix[i % len(mix)]
        (d / "meshes" / f"{i:02d}_{src.name}").write_text(src.read_text() + f"\n# copy {i}\n")
    cfg = _config(d)
    _cli(["run", str(cfg), "--jobs", "2"])  # warm
    t1 = [_cli(["run", str(cfg), "--jobs", "1", "--force"]) for _ in range(2)]
    t2 = [_cli(["run", str(cfg), "--jobs", "2", "--force"]) for _ in range(2)]
    return {
        "assets": 20,
        "jobs1_s": statistics.median(t1),
        "jobs2_s": statistics.median(t2),
        "speedup": statistics.median(t1) / statistics.median(t2),
    }


def rerun(work: Path) -> dict:
    import numpy as np
    import trimesh

    d = work / "rerun"
    (d / "meshes").mkdir(parents=True)
    rng = np.random.default_rng(0)
    for i in range(100):
        s = trimesh.creation.icosphere(subdivisions=2)
        s.vertices += 0.01 * rng.standard_normal(s.vertices.shape)
        s.export(d / "meshes" / f"s{i:03d}.obj")
    cfg = _config(d)
    _cli(["run", str(cfg), "--jobs", "2"])
    times = [_cli(["run", str(cfg)]) for _ in range(3)]
    return {"assets": 100, "rerun_s_median": statistics.median(times), "rerun_s_all": times}


def many(work: Path, count: int = 1000) -> dict:
    from swpm_usd.pipeline import run

    d = work / "many"
    (d / "meshes").mkdir(parents=True)
    text = (SHARED / "suzanne.obj").read_text()
    for i in range(count):
        (d / "meshes" / f"m{i:04d}.obj").write_text(f"{text}\n# copy {i}\n")
    cfg = _config(d).read_text().replace("encoding: skip-strip", "encoding: vanilla")
    (d / "pipeline.yaml").write_text(cfg)
    t = time.perf_counter()
    res = run(d / "pipeline.yaml", echo=lambda m: None)
    wall = time.perf_counter() - t
    work_s = sum(r["seconds"] for r in res.records.values())
    return {"assets": len(res.records), "wall_s": wall, "asset_work_s": work_s, "overhead": 1 - work_s / wall}


def _copies_built(d: Path, source: str, names: list[str], output: str) -> None:
    """``d/meshes/<name>``: a copy of the shared mesh ``source`` each (a comment line apart, so each hashes
    differently), built once as vanilla with ``output``; kept if ``d`` holds that build (``--work``)."""
    if (d / "out" / "manifest.json").is_file():  # (--work: built by an earlier call)
        return
    (d / "meshes").mkdir(parents=True, exist_ok=True)
    text = (SHARED / source).read_text()
    for i, name in enumerate(names):
        (d / "meshes" / name).write_text(f"{text}\n# copy {i}\n")
    (d / "pipeline.yaml").write_text(
        f"version: 1\nassets: [{{glob: 'meshes/*.obj'}}]\noutput: {output}\ndefaults: {{encoding: vanilla}}\n"
    )
    _cli(["run", str(d / "pipeline.yaml"), "--jobs", "2"])


def rerun_large(work: Path, source: str = "bob.obj", copies: int = 200, repeats: int = 5) -> dict:
    from swpm_usd.pipeline import run

    d = work / "rerun-large"
    cfg = d / "pipeline.yaml"
    _copies_built(d, source, [f"{i:03d}_{source}" for i in range(copies)], "{dir: out, report: false}")
    size = sum(p.stat().st_size for p in (d / "meshes").iterdir())
    _cli(["run", str(cfg)])  # settle (see the docstring)
    cli = [_cli(["run", str(cfg)]) for _ in range(repeats)]
    inproc = []
    for _ in range(repeats):
        res = run(cfg, echo=lambda m: None)
        assert res.built == 0, "the rerun built something: the project is not up to date"
        inproc.append(res.seconds)
    cold = []
    for _ in range(repeats):
        _evict(d / "meshes")
        cold.append(_cli(["run", str(cfg)]))
    return {
        "assets": copies,
        "input_mb": size / 1e6,
        "cli_s_median": statistics.median(cli),
        "cli_s_all": cli,
        "run_s_median": statistics.median(inproc),
        "run_s_all": inproc,
        "cold_cli_s_median": statistics.median(cold),
        "cold_cli_s_all": cold,
    }


def rerun_usd(work: Path, copies: int = 200, repeats: int = 7) -> dict:
    """An up-to-date rerun of ``copies`` small glob-matched ``.usda`` assets (an icosphere each, 320
    triangles, in a layer that references another), as ``run()`` in this process (the run's own time) and
    as a fresh ``swpm-pipeline run`` (wall time): medians of ``repeats`` after one settling rerun. Listing
    such a file's inputs opens it as a USD stage (its layers are its inputs), which a rerun did for every
    asset before it took the list its manifest record holds."""
    import trimesh
    from pxr import Usd, UsdGeom

    from swpm_usd.pipeline import run

    d = work / "rerun-usd"
    cfg = d / "pipeline.yaml"
    if not (d / "out" / "manifest.json").is_file():  # (--work: built by an earlier call)
        (d / "meshes" / "geo").mkdir(parents=True, exist_ok=True)
        sphere = trimesh.creation.icosphere(subdivisions=2)
        for i in range(copies):
            geo = d / "meshes" / "geo" / f"geo{i:03d}.usda"  # (not matched: the layer a matched file uses)
            layer = Usd.Stage.CreateInMemory()
            layer.SetDefaultPrim(UsdGeom.Xform.Define(layer, "/G").GetPrim())
            m = UsdGeom.Mesh.Define(layer, "/G/Mesh")
            m.CreatePointsAttr((sphere.vertices * (1 + i / copies)).tolist())
            m.CreateFaceVertexCountsAttr([3] * len(sphere.faces))
            m.CreateFaceVertexIndicesAttr(sphere.faces.reshape(-1).tolist())
            layer.GetRootLayer().Export(str(geo))
            st = Usd.Stage.CreateNew(str(d / "meshes" / f"s{i:03d}.usda"))
            st.SetDefaultPrim(st.DefinePrim("/S", "Xform"))
            st.GetDefaultPrim().GetReferences().AddReference(f"./geo/{geo.name}")
            st.GetRootLayer().Save()
        cfg.write_text(
            "version: 1\nassets: [{glob: 'meshes/*.usda'}]\noutput: {dir: out, report: false}\n"
            "defaults: {encoding: vanilla}\n"
        )
        _cli(["run", str(cfg), "--jobs", "2"])
    _cli(["run", str(cfg)])  # settle (inputs written just before the build are hashed again once)
    inproc = []
    for _ in range(repeats):
        res = run(cfg, echo=lambda m: None)
        assert res.built == 0 and res.skipped == copies, "the rerun built something: not up to date"
        inproc.append(res.seconds)
    cli = [_cli(["run", str(cfg)]) for _ in range(repeats)]
    return {
        "assets": copies,
        "run_s_median": statistics.median(inproc),
        "run_s_all": inproc,
        "cli_s_median": statistics.median(cli),
        "cli_s_all": cli,
    }


def scene(work: Path, counts: tuple[int, ...] = (1000, 5000, 10000), repeats: int = 3) -> dict:
    import swpm_usd
    from swpm_usd import usd
    from swpm_usd.pipeline.runner import _write_scene

    d = work / "scene"
    d.mkdir(parents=True, exist_ok=True)
    first = d / "a00000.usdc"
    if not first.exists():
        usd.write(swpm_usd.build(SHARED / "suzanne.obj", encoding="vanilla"), first)
    res = {}
    for n in counts:
        records = {}
        for i in range(n):
            layer = d / f"a{i:05d}.usdc"
            if not layer.exists():
                os.link(first, layer)
            records[f"meshes/a{i:05d}.obj"] = {"status": "built", "outputs": {"usd": {"path": layer.name}}}
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            _write_scene(d, records)
            times.append(time.perf_counter() - t)
        res[str(n)] = {
            "scene_s_median": statistics.median(times),
            "scene_bytes": (d / "scene.usda").stat().st_size,
        }
    return res


def rerun_10k(work: Path, count: int = 10000, repeats: int = 5) -> dict:
    """A rerun with nothing changed over ``count`` built assets (copies of suzanne, vanilla, each with its
    USD layer; scene.usda and report.html asked for), as a fresh ``swpm-pipeline run --jobs 2`` (wall time,
    medians of ``repeats`` after one settling rerun), whether it rewrote manifest.json, scene.usda and
    report.html (their mtime moved), the sizes of those, the report written in this process (seconds), and
    where one rerun's time goes (cProfile of a fresh process, which slows it 2-3 times: the package's top
    functions by cumulative time, and all by own time). ``--work DIR`` keeps the built project (building it
    takes several minutes), as in 5."""
    import cProfile  # noqa: F401 - (the profile runs in a child process; the import checks it exists)
    import pstats

    import swpm_usd

    d = work / "rerun-10k"
    cfg = d / "pipeline.yaml"
    out = d / "out"
    names = [f"m{i:05d}.obj" for i in range(count)]
    _copies_built(d, "suzanne.obj", names, "{dir: out, usd: true, scene: true, report: true}")
    _cli(["run", str(cfg), "--jobs", "2"])  # settle (inputs written just before the build are hashed again)
    names = ("manifest.json", "scene.usda", "report.html")

    def mtimes() -> list[int]:
        return [(out / n).stat().st_mtime_ns for n in names]

    before = mtimes()
    cli = [_cli(["run", str(cfg), "--jobs", "2"]) for _ in range(repeats)]
    rewritten = [n for n, a, b in zip(names, before, mtimes(), strict=True) if a != b]
    prof = d / "rerun.prof"
    root = str(Path(swpm_usd.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p)}
    profiled = [sys.executable, "-m", "cProfile", "-o", str(prof), "-m", "swpm_usd.cli", "run", str(cfg)]
    subprocess.run([*profiled, "--jobs", "2"], check=True, capture_output=True, cwd=HERE, env=env)
    stats = pstats.Stats(str(prof))
    total = stats.total_tt  # type: ignore[attr-defined]

    def top(key: int, n: int = 15, ours: bool = False) -> list[str]:
        """The ``n`` functions of most time (``key``: 2 own, 3 cumulative), of the package alone if ``ours``
        (cumulative: the command's own frames above them hold it all)."""
        rows = [
            kv
            for kv in stats.stats.items()  # type: ignore[attr-defined]
            if not ours or f"{os.sep}swpm_usd{os.sep}" in kv[0][0] and not kv[0][0].endswith("cli.py")
        ]
        rows = sorted(rows, key=lambda kv: -kv[1][key])[:n]
        return [f"{v[key]:7.3f} s  {Path(f).name}:{line}({fn})" for (f, line, fn), v in rows]

    from swpm_usd.pipeline.report import write_report

    manifest = json.loads((out / "manifest.json").read_text())
    report_s = []
    for _ in range(3):
        t = time.perf_counter()
        write_report(d / "report-bench.html", manifest)
        report_s.append(time.perf_counter() - t)
    return {
        "assets": count,
        "cli_s_median": statistics.median(cli),
        "cli_s_all": cli,
        "rewritten": rewritten,
        "bytes": {n: (out / n).stat().st_size for n in names},
        "report_write_s_median": statistics.median(report_s),
        "report_bench_bytes": (d / "report-bench.html").stat().st_size,
        "profile_total_s": total,
        "profile_cumulative": top(3, ours=True),
        "profile_own": top(2),
    }


SCALE_CONFIG = """version: 1
assets: [{glob: "assets/**/*.*", instances: 2}]
output: {dir: out, swpm: true, usd: true, scene: true, report: true}
defaults: {encoding: vanilla}
rules:
  - {name: chars, match: {path: "assets/chars/**"}, encoding: skip-strip}
  - {name: tiny, match: {triangles: {max: 400}}, encoding: vanilla}
  - {name: vfx, match: {path: "assets/vfx/*"}, encoding: sliding-window, params: {cache_size: 16}}
  - {name: rest, encoding: vanilla}
"""


def _scale_assets(d: Path, count: int) -> list[Path]:
    """``count`` small assets under ``d/assets`` (see section 9 of the docstring); the good ones, in order."""
    import numpy as np
    import trimesh
    from trimesh.exchange.gltf import export_gltf

    base = [
        trimesh.load(SHARED / "suzanne.obj", force="mesh"),
        trimesh.creation.icosphere(subdivisions=2),
        trimesh.creation.icosphere(subdivisions=3),
        trimesh.creation.capsule(count=[12, 12]),
        trimesh.creation.cylinder(0.5, 1.0, sections=24),
    ]
    folders = [
        "props",
        "props/small",
        "chars/héros",
        "env/rocks and stones",
        "env/trees/oak",
        "vfx",
        "misc/日本",
    ]
    exts = ["obj", "ply", "stl", "glb", "gltf", "usda"]
    good: list[Path] = []
    for i in range(count):
        folder = d / "assets" / folders[i % len(folders)]
        folder.mkdir(parents=True, exist_ok=True)
        stem = f"asset_{i:05d}" if i % 17 else f"asset {i:05d} ünï"
        p = folder / f"{stem}.{exts[i % len(exts)]}"
        if i % 50 == 49:  # broken: 2 %
            kind = (i // 50) % 3
            if kind == 0:
                p.write_bytes(b"")
            elif kind == 1:
                p.with_suffix(".ply").write_bytes(
                    b"ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty float x\n"
                    b"property float y\nproperty float z\nend_header\n" + b"\0" * 64
                )
            else:
                p.with_suffix(".obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 9\n")
            continue
        if i % 31 == 30 and good and good[-1].suffix == p.suffix and good[-1].suffix != ".gltf":
            shutil.copyfile(good[-1], p)  # a duplicate, byte for byte
            good.append(p)
            continue
        m = base[i % len(base)].copy()
        m.apply_scale(1.0 + (i % 7) * 0.1)
        m.vertices = m.vertices + np.random.default_rng(i).normal(scale=1e-3, size=m.vertices.shape)
        if p.suffix == ".usda":
            pts = ",".join(f"({x:.6g},{y:.6g},{z:.6g})" for x, y, z in m.vertices)
            idx = ",".join(str(int(v)) for v in m.faces.ravel())
            counts = ",".join(["3"] * len(m.faces))
            p.write_text(
                '#usda 1.0\n(\n    defaultPrim = "m"\n    upAxis = "Y"\n    metersPerUnit = 1\n)\n'
                f'def Mesh "m"\n{{\n    int[] faceVertexCounts = [{counts}]\n'
                f"    int[] faceVertexIndices = [{idx}]\n    point3f[] points = [{pts}]\n}}\n"
            )
        elif p.suffix == ".gltf":
            files = export_gltf(m, embed_buffers=bool(i % 2))
            text = files["model.gltf"].decode()
            for name, data in files.items():
                if name.endswith(".bin"):  # (a name of its own: trimesh names every one gltf_buffer_N.bin)
                    (folder / f"{stem}_{name}").write_bytes(data)
                    text = text.replace(f'"{name}"', f'"{stem}_{name}"')
            p.write_text(text)
        else:
            m.export(p)
        good.append(p)
    return good


def _edit_input(p: Path) -> None:
    """Change the bytes of the input ``p`` (one of :func:`_scale_assets`'s) and not its mesh: the file still
    loads, to the same triangles. (A trailing byte is no such edit for binary PLY and STL, whose loaders
    refuse bytes after the data their header declares: the "edited" assets failed instead of rebuilding.)"""
    if p.suffix in (".obj", ".usda", ".gltf"):
        with open(p, "a") as f:
            f.write("\n")
    elif p.suffix == ".ply":  # a comment line in the header
        data = p.read_bytes()
        end = data.index(b"\n") + 1
        p.write_bytes(data[:end] + b"comment edited\n" + data[end:])
    elif p.suffix == ".stl":  # binary: the 80-byte header is free text (kept from starting with "solid")
        with open(p, "r+b") as f:
            f.seek(79)
            byte = f.read(1)
            f.seek(79)
            f.write(b"x" if byte != b"x" else b"y")
    else:  # .glb: bytes after the chunks its header counts are ignored
        with open(p, "ab") as f:
            f.write(b"\0")


def _cli_rusage(args: list[str], cwd: Path, failed: int = 0) -> tuple[float, int, str]:
    """Wall time, peak RSS (KB, the largest process of the run: ``wait4``'s) and stdout of a fresh
    ``swpm-pipeline`` process running the code this one imports (as :func:`_cli`). A run that does not end
    as expected raises, with its stderr: exit 0, or with ``failed`` assets exit 1 and ``--json``'s
    ``failed`` that count (a run that failed for another reason, a usage error or a crash, timed no run)."""
    import swpm_usd

    root = str(Path(swpm_usd.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p)}
    t = time.perf_counter()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(CLI + args, cwd=cwd, env=env, stdout=out, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = code = os.waitstatus_to_exitcode(status)  # (reaped by wait4)
        wall = time.perf_counter() - t
        out.seek(0)
        text = out.read().decode()
        err.seek(0)
        problem = None
        if code != (1 if failed else 0):
            problem = f"exited with code {code}"
        elif failed and "--json" in args:
            try:
                got = json.loads(text).get("failed")
            except (ValueError, AttributeError):
                got = "no JSON"
            if got != failed:
                problem = f"failed {got} assets, not the {failed} broken"
        if problem is not None:
            tail = err.read().decode(errors="replace")[-2000:]
            raise RuntimeError(f"swpm-pipeline {' '.join(args)} (in {cwd}) {problem}:\n{tail}")
        return wall, usage.ru_maxrss, text


def scale(work: Path, counts: tuple[int, ...] = (500, 1000, 2000, 4000)) -> dict:
    res = {}
    for n in counts:
        d = work / f"scale-{n}"
        if d.exists():
            shutil.rmtree(d)
        good = _scale_assets(d, n)
        (d / "pipeline.yaml").write_text(SCALE_CONFIG)
        cmd = ["run", str(d / "pipeline.yaml"), "--jobs", "2", "--json"]
        broken = n // 50  # (each run fails those: exit 1)
        first_s, first_rss, text = _cli_rusage(cmd, d, broken)
        first = json.loads(text)
        dry_s, _, _ = _cli_rusage([*cmd, "--dry-run"], d)
        _cli_rusage(cmd, d, broken)  # (settling: inputs written just before the build are hashed again once)
        rerun_s, rerun_rss, _ = _cli_rusage(cmd, d, broken)
        some = good[:: max(1, len(good) // max(1, n // 100))][: max(1, n // 100)]  # 1 %, spread
        for p in some:
            os.utime(p)
        touched_s, _, text = _cli_rusage(cmd, d, broken)
        touched_built = json.loads(text)["built"]
        for p in some:
            _edit_input(p)
        edited_s, _, text = _cli_rusage(cmd, d, broken)
        edited = json.loads(text)
        out = d / "out"
        res[str(n)] = {
            "built": first["built"],
            "failed": first["failed"],
            "first_run_s": first_s,
            "first_run_max_rss_kb": first_rss,
            "dry_run_s": dry_s,
            "rerun_s": rerun_s,
            "rerun_max_rss_kb": rerun_rss,
            "touched": len(some),
            "touched_rerun_s": touched_s,
            "touched_built": touched_built,
            "edited_rerun_s": edited_s,
            "edited_built": edited["built"],
            "edited_failed": edited["failed"],
            "bytes": {
                **{f: (out / f).stat().st_size for f in ("manifest.json", "report.html", "scene.usda")},
                "json": len(text),
            },
        }
    return res


def _evict(folder: Path) -> None:
    """Drop the files of ``folder`` from the page cache (theirs alone: no root, no other process's files)."""
    for p in folder.iterdir():
        with open(p, "rb") as f:
            os.fsync(f.fileno())  # (dirty pages are not dropped)
            os.posix_fadvise(f.fileno(), 0, 0, os.POSIX_FADV_DONTNEED)


SECTIONS = {
    "overhead": overhead,
    "scaling": scaling,
    "rerun": rerun,
    "many": many,
    "rerun-large": rerun_large,
    "rerun-usd": rerun_usd,
    "scene": scene,
    "rerun-10k": rerun_10k,
    "scale": scale,
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(HERE / "results" / "pipeline.json"))
    ap.add_argument("--only", nargs="+", choices=list(SECTIONS), help="run these sections alone")
    ap.add_argument("--work", help="work in this folder (kept; rerun-large reuses its build)")
    ap.add_argument("--assets", nargs="+", type=int, help="scale: these asset counts (500 1000 2000 4000)")
    args = ap.parse_args()
    if args.assets:
        SECTIONS["scale"] = lambda work: scale(work, tuple(args.assets))
    with contextlib.ExitStack() as stack:
        work = Path(args.work) if args.work else Path(stack.enter_context(tempfile.TemporaryDirectory()))
        res = {name: SECTIONS[name](work) for name in (args.only or SECTIONS)}
    print(f"{'measure':<40} {'value':>10} {'target':>10}")
    if "overhead" in res:
        o = res["overhead"]
        print(f"{'overhead, shared meshes, jobs 1':<40} {100 * o['overhead']:>9.1f}% {'<= 10%':>10}")
        print(f"{'  (wall s / per-asset work s)':<40} {o['wall_s']:>5.1f}/{o['asset_work_s']:<4.1f}")
    if "scaling" in res:
        s = res["scaling"]
        print(f"{'jobs 2 speed-up, 20 assets':<40} {s['speedup']:>9.2f}x {'>= 1.7x':>10}")
        print(f"{'  (jobs 1 s / jobs 2 s)':<40} {s['jobs1_s']:>5.1f}/{s['jobs2_s']:<4.1f}")
    if "rerun" in res:
        print(f"{'rerun, 100 assets unchanged':<40} {res['rerun']['rerun_s_median']:>9.2f}s {'<= 2 s':>10}")
    if "many" in res:
        n = res["many"]
        print(f"{'overhead, 1,000 small assets, jobs 1':<40} {100 * n['overhead']:>9.1f}% {'<= 10%':>10}")
        print(f"{'  (wall s / per-asset work s)':<40} {n['wall_s']:>5.1f}/{n['asset_work_s']:<4.1f}")
    if "rerun-large" in res:
        g = res["rerun-large"]
        what = f"rerun, {g['assets']} x {g['input_mb'] / g['assets']:.2f} MB unchanged"
        print(f"{what:<40} {g['cli_s_median']:>9.2f}s {'':>10}")
        print(f"{'  (run() in process s)':<40} {g['run_s_median']:>9.2f}s")
        print(f"{'  (inputs evicted from the page cache s)':<40} {g['cold_cli_s_median']:>9.2f}s")
    if "rerun-usd" in res:
        u = res["rerun-usd"]
        what = f"rerun, {u['assets']} small .usda unchanged"
        print(f"{what:<40} {u['cli_s_median']:>9.2f}s {'':>10}")
        print(f"{'  (run() in process s)':<40} {u['run_s_median']:>9.3f}s")
    if "scene" in res:
        for n, v in res["scene"].items():
            what = f"scene.usda, {int(n):,} asset layers"
            target = "<= 1 s" if n == "10000" else ""
            print(f"{what:<40} {v['scene_s_median']:>9.2f}s {target:>10}")
    if "rerun-10k" in res:
        r = res["rerun-10k"]
        print(f"{'rerun, 10,000 small assets unchanged':<40} {r['cli_s_median']:>9.2f}s")
        print(f"{'  (rewritten)':<40} {', '.join(r['rewritten']) or 'nothing':>10}")
        print(f"{'  (manifest.json / report.html MB)':<40} {r['bytes']['manifest.json'] / 1e6:>5.1f}/"
              f"{r['bytes']['report.html'] / 1e6:<4.1f}")  # fmt: skip
        print(f"{'  (a report written in process MB / s)':<40} {r['report_bench_bytes'] / 1e6:>5.1f}/"
              f"{r['report_write_s_median']:<4.2f}")  # fmt: skip
        print(f"  profile of one rerun ({r['profile_total_s']:.2f} s), cumulative:")
        print("\n".join("    " + line for line in r["profile_cumulative"]))
        print("  own time:")
        print("\n".join("    " + line for line in r["profile_own"]))
    if "scale" in res:
        print(f"{'scale, jobs 2 (s; MB)':<24} {'first':>7} {'dry':>6} {'rerun':>6} {'touch':>6} {'edit':>6} "
              f"{'RSS':>5} {'manif':>6} {'report':>6} {'json':>6}")  # fmt: skip
        for n, v in res["scale"].items():
            b = v["bytes"]
            print(f"{int(n):>6,} assets ({v['failed']:>3} fail) {v['first_run_s']:>7.1f} "
                  f"{v['dry_run_s']:>6.2f} "
                  f"{v['rerun_s']:>6.2f} {v['touched_rerun_s']:>6.2f} {v['edited_rerun_s']:>6.2f} "
                  f"{v['first_run_max_rss_kb'] / 1024:>5.0f} {b['manifest.json'] / 1e6:>6.2f} "
                  f"{b['report.html'] / 1e6:>6.2f} {b['json'] / 1e6:>6.3f}")  # fmt: skip
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if args.only and out.exists():  # the other sections' results of an earlier run stay
        try:
            res = {**json.loads(out.read_text()), **res}
        except (ValueError, TypeError):
            pass
    out.write_text(json.dumps(res, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
