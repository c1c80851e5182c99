"""The probe server's program, which :mod:`.probe` runs as ``python -c`` :data:`_PROBE`, and the answer codes
the program and :mod:`.probe` share.

A program of its own, kept apart from the module that starts and talks to it: it runs in another process,
imports nothing of this package (usd-core alone), and a newcomer reads it as the server's code, the
client's being :mod:`.probe`. Its text is passed as it stands here (a string, not a module imported: this
process never imports usd-core for it).
"""

from __future__ import annotations

#: a probe's answers: usd-core opened and read the file, raised an error opening it, or reading a value in
#: it (its first message beside)
_CLEAN, _OPEN_FAILED, _READ_FAILED, _LAYER_FAILED = 0, 3, 4, 6
#: a probe's answer: a layer its stage names is not a regular file (message: its st_mode, "|", its real path)
_NOT_REGULAR = 7

#: the probe server's program: argv[1] the schema plugin's folder (registered as this process registers it:
#: its fallbacks are values read too; through PXR_PLUGINPATH_NAME, usd-core 26.11 raises "There already is
#: a type named 'SwpmMeshAPI'" at the first stage's open), argv[2] the pid of the process that asks. It reads
#: requests, one JSON line each (a tag, the file, its seconds and its address-space limit in bytes), forks a
#: process that probes the file under those limits (several at once), and answers each with a JSON line:
#: [tag, code, message, the real files of the layers the stage used and those its composition errors name],
#: the code the probe's (``_CLEAN``, ``_OPEN_FAILED``, ``_READ_FAILED``, ``_LAYER_FAILED``: a crate file the
#: stage names exists but did not open, ``_NOT_REGULAR``, 5: the probe failed itself) or minus the signal it
#: died by (SIGALRM: out of time). A probe names each layer to the server (a JSON string, a line) before it
#: opens it: the layers of an answer are those too, all a probe that crashed or hung reached. It ends,
#: killing its probes, when its input does or its parent process is gone
_PROBE = r"""
import ctypes, json, os, re, resource, select, signal, stat, sys
signal.signal(signal.SIGINT, signal.SIG_IGN)
PARENT = int(sys.argv[2])
OUT = None  # (a probe's end of its pipe to the server)
from pxr import Ar, Plug, Sdf, Tf, Usd
try:
    Plug.Registry().RegisterPlugins(sys.argv[1])
except Exception:
    pass
def warm():
    # usd-core's first stage in a process builds its schema registry (reads every plugin's schemas: ~25 ms,
    # most of a small file's probe): done once here, on a stage of our own in memory, each fork inherits it
    from pxr import UsdGeom
    Sdf.FileFormat.FindByExtension("usdc")
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.Mesh.Define(stage, "/m").CreatePointsAttr()
    for prim in stage.Traverse():
        prim.GetAllMetadata()
        for attr in prim.GetAttributes():
            attr.GetAllMetadata()
            attr.Get()
try:
    warm()
except Exception:
    pass
def note(real):
    # a layer named to the server before it is opened: a probe that crashes or hangs is keyed on it
    os.write(OUT, (json.dumps(real) + "\n").encode())
def arcs(layer):
    # the asset paths of a layer's references and payloads outside variants (the stage's open opens them
    # whatever the selections), and those inside a variant (opened only when it is selected)
    always, varied, todo = [], [], [(child, False) for child in layer.pseudoRoot.nameChildren]
    while todo:
        spec, inside = todo.pop()
        for has, items in ((spec.hasReferences, spec.referenceList), (spec.hasPayloads, spec.payloadList)):
            for item in items.GetAddedOrExplicitItems() if has else ():
                if item.assetPath:
                    (varied if inside else always).append(item.assetPath)
        todo.extend((child, inside) for child in spec.nameChildren)
        if spec.variantSets:
            for variants in spec.variantSets.values():
                todo.extend((variant.primSpec, True) for variant in variants.variants.values())
    return always, varied
def preopen(path):
    # the stage's layers (sublayers, references, payloads, through every layer they name) opened one by one
    # before the stage (held: its open finds them), each named to the server first; one that is not a
    # regular file (a FIFO, whose open waits for a writer) is answered at once, never opened (the alarm is
    # left for a layer named no other way). A layer that does not open is left to the stage's open. A layer
    # only a variant names is named, not opened (the stage opens it only if the variant is selected: one
    # that crashes usd-core in a variant not selected is no crash of the stage), but for a text one (whose
    # parser fails cleanly): read, the layers it names are named too (a crash in one, its variant selected,
    # is keyed on it, not on the layers naming it), as only a variant names them; a crate one's are named
    # so too, read in a process of its own (crate_names)
    root = os.path.abspath(path)
    held, seen, todo = [], {}, [(root, False)]  # (seen: real path -> whether only a variant names it)
    while todo:
        spelled, varied_only = todo.pop()
        real = os.path.realpath(spelled)
        if real in seen and (varied_only or not seen[real]):
            continue
        seen[real] = varied_only
        if spelled != root and not real.lower().endswith((".usd", ".usda", ".usdc", ".usdz")):
            continue
        note(real)
        if varied_only and not os.path.isfile(real):
            continue  # (named, not opened)
        if varied_only and crate(real):
            # (named, not opened here; what it names is read in a process of its own, and named in turn)
            todo.extend((found, True) for found in crate_names(spelled))
            continue
        try:
            mode = os.stat(real).st_mode
        except OSError:
            continue
        if not stat.S_ISREG(mode):
            return f"{mode}|{real}", held  # (the asking process says what it is: _file_kind)
        try:
            layer = Sdf.Layer.FindOrOpen(spelled)
            assets = list(layer.GetCompositionAssetDependencies()) if layer else []
        except Exception:
            continue
        held.append(layer)
        varied = []
        if layer and set(assets) - set(layer.subLayerPaths):  # (references or payloads: in a variant, maybe)
            try:
                always, varied = arcs(layer)
                assets = [*layer.subLayerPaths, *always]
            except Exception:
                varied = []  # (each layer it names opened)
        opens = set(assets)
        for asset in [*assets, *varied]:
            # (one only a variant names: a crash of the stage's open in it is keyed on it too)
            todo.append((resolved(asset, layer), varied_only or asset not in opens))
    return "", held
def resolved(asset, layer):
    # the file an asset path of ``layer`` names, as the stage's open resolves it (no package's inner part)
    resolver = Ar.GetResolver()
    try:
        found = str(resolver.Resolve(resolver.CreateIdentifier(asset, layer.resolvedPath)))
    except Exception:
        found = ""
    if not found:
        found = os.path.join(os.path.dirname(str(layer.resolvedPath)), asset)
    return found.split("[", 1)[0]
def crate_names(spelled):
    # the files a crate layer only a variant names names in turn (its sublayers, references, payloads),
    # read in a process forked from this probe: a crash in it (its variant maybe not selected) is not the
    # stage's, and the layers it names are named to the server before the stage's open, so that a crash of
    # the open in one of them, its variant selected, is keyed on it (as for a text layer a variant names). []
    # when it does not read (the stage's open meets it, if its variant is selected). It has half of this
    # probe's time left (its own alarm): one that hangs is killed then, and the stage's open has the rest (it
    # took all of the probe's, a hang in a variant not selected a timeout of the stage)
    left = signal.alarm(0)
    signal.alarm(left)
    r, w = os.pipe()
    try:
        pid = os.fork()
    except OSError:
        os.close(r)
        os.close(w)
        return []
    if pid == 0:
        os.close(r)
        signal.alarm(max(1, left // 2) if left else 0)
        try:
            os.close(OUT)  # (the server's end of this probe's answer is not held open by this one)
        except (OSError, TypeError):
            pass
        found = []
        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG: dies with us
            layer = Sdf.Layer.FindOrOpen(spelled)
            if layer:
                always, varied = arcs(layer)
                names = [*layer.GetCompositionAssetDependencies(), *always, *varied]
                found = sorted({resolved(asset, layer) for asset in names if asset})
        except Exception:
            pass
        os.write(w, json.dumps(found).encode())
        os._exit(0)
    os.close(w)
    chunks = []
    while True:
        data = os.read(r, 1 << 16)
        if not data:
            break
        chunks.append(data)
    os.close(r)
    os.waitpid(pid, 0)
    try:
        found = json.loads(b"".join(chunks))
    except ValueError:  # (it died: cut short, or nothing)
        return []
    return [str(f) for f in found] if isinstance(found, list) else []
def probe(path):
    odd, held = preopen(path)
    if odd:
        return 7, odd, []
    try:
        stage = Usd.Stage.Open(path)
    except Exception as exc:
        return 3, str(exc), []
    if stage is None:
        return 3, "", []
    del held
    for layer in stage.GetUsedLayers():  # (the layers its values are read from, named before they are)
        if layer.realPath:
            note(os.path.realpath(layer.realPath.split("[", 1)[0]))
    failed = []
    def attempt(fn, *args):
        try:
            return fn(*args)
        except Tf.ErrorException as exc:
            failed.append(str(exc))
        except UnicodeDecodeError as exc:
            failed.append(f"a text value (token or string) is not UTF-8: {exc}")
        except Exception:
            pass
        return None
    def read_meta(obj):
        # a list op's items (apiSchemas') are made Python text only when asked for: asked here
        for value in (attempt(obj.GetAllMetadata) or {}).values():
            if hasattr(value, "prependedItems"):
                for kind in ("explicit", "added", "prepended", "appended", "deleted"):
                    attempt(getattr, value, kind + "Items")
    def read_prim(prim):
        read_meta(prim)
        for prop in attempt(prim.GetProperties) or []:
            read_meta(prop)
            if isinstance(prop, Usd.Attribute):
                value = attempt(prop.Get)
                if type(value).__name__ in ("TokenArray", "StringArray"):  # (made Python text as read)
                    attempt(lambda value=value: [str(v) for v in value])
                times = attempt(prop.GetTimeSamples) or []
                for t in times[:1] + times[-1:]:
                    attempt(prop.Get, t)
            else:
                attempt(prop.GetTargets)
    for root in [stage.GetPseudoRoot()] + list(attempt(stage.GetPrototypes) or []):
        for prim in Usd.PrimRange.AllPrims(root):
            read_prim(prim)
    used = attempt(stage.GetUsedLayers) or []
    # the real files of the layers it used (a package's inner layer: the package; a layer reached through a
    # linked folder: its file, as the root's key and the files a text root names are)
    opened = {os.path.realpath(layer.realPath.split("[", 1)[0]) for layer in used if layer.realPath}
    named = set()  # (the files its composition errors name: one not there now is a file it depends on)
    for error in attempt(stage.GetCompositionErrors) or []:
        # (an absolute path: a file; not an anonymous layer's or a search path's name)
        assets = [
            os.path.realpath(a.split("[", 1)[0]) if os.path.isabs(a) else ""
            for a in re.findall(r"@([^@]+)@", str(error))
        ]
        named.update(a for a in assets if a)
        # a crate file the stage names that exists but did not open here (under the memory limit: one
        # asking for a giant allocation), which the caller's process, without the limit, would open
        asset = assets[0] if assets else ""
        if asset and asset not in opened and os.path.isfile(asset) and crate(asset):
            return 6, f"{asset}: {error}", sorted(opened | named)
    layers = sorted(opened | named)
    def read_spec(layer, path):
        spec = attempt(layer.GetObjectAtPath, path)
        if spec is None:
            return
        for key in attempt(spec.ListInfoKeys) or []:
            attempt(spec.GetInfo, key)
        for t in attempt(layer.ListTimeSamplesForPath, path) or []:
            attempt(layer.QueryTimeSample, path, t)
    for layer in used:
        attempt(layer.Traverse, Sdf.Path.absoluteRootPath, lambda p, layer=layer: read_spec(layer, p))
    # the files of the layers the stage uses, as the asking process lists them (a package's inner layer:
    # the package), so that it need not open the stage itself to know them (a large crate parsed once more)
    files = sorted({Ar.SplitPackageRelativePathOuter(layer.realPath)[0] for layer in used if layer.realPath})
    return (4, failed[0], layers) if failed else (0, "", layers, files)
def crate(path):
    if path.lower().endswith((".usdc", ".usdz")):
        return True
    try:
        with open(path, "rb") as f:
            return not path.lower().endswith(".usda") and f.read(8) == b"PXR-USDC"
    except OSError:
        return False
def start(line):
    tag, path, seconds, memory = json.loads(line)
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        global OUT
        os.close(r)
        OUT = w
        try:
            # (killed with this server, should it be killed itself: no probe outlives it)
            ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except Exception:
            pass
        if os.getppid() != SERVER:
            os._exit(1)
        try:
            resource.setrlimit(resource.RLIMIT_AS, (memory, resource.RLIM_INFINITY))
        except (ValueError, OSError):
            pass
        signal.alarm(max(1, int(seconds)))
        try:
            answer = probe(path)
        except BaseException as exc:  # (the probe's own failure, outside its guarded reads)
            answer = 5, f"{type(exc).__name__}: {exc}", []
        with os.fdopen(w, "w") as out:
            out.write(json.dumps(answer))
        os._exit(0)
    os.close(w)
    running[r] = (tag, pid, [])
def finish(fd):
    tag, pid, chunks = running.pop(fd)
    os.close(fd)
    _, status = os.waitpid(pid, 0)
    layers, answer = set(), None  # (the layers it named as it went, its answer: the last line)
    for line in b"".join(chunks).split(b"\n"):
        try:
            item = json.loads(line)
        except ValueError:  # (a line cut short by its death)
            continue
        if isinstance(item, str):
            layers.add(item)
        elif isinstance(item, list) and len(item) in (3, 4):
            answer = [*item, []][:4]  # (the files of the layers its stage uses: a clean answer's alone)
    if os.WIFSIGNALED(status):
        answer = [-os.WTERMSIG(status), crash_report(pid), sorted(layers), []]
    elif answer is None:
        code = os.waitstatus_to_exitcode(status)
        answer = [5, f"the probe process ended (exit {code}) without an answer", [], []]
    else:
        answer[2] = sorted(layers.union(answer[2]))
    os.write(1, (json.dumps([tag, *answer]) + "\n").encode())
def crash_report(pid):
    # usd-core's fatal error handler writes st_<program>.<pid> to its temporary folder (TMPDIR: one of
    # this server's own, not /var/tmp, where every corrupt file probed would leave one): its first line is
    # what usd-core said; the file is removed
    folder = os.environ.get("SWPM_PROBE_CRASH_DIR")
    if not folder:
        return ""
    said = ""
    try:
        names = [n for n in os.listdir(folder) if n.startswith("st_") and n.endswith(f".{pid}")]
    except OSError:
        return ""
    for name in names:
        try:
            with open(os.path.join(folder, name), "rb") as f:
                head = f.read(4096).decode("utf-8", "replace").splitlines()
            os.unlink(os.path.join(folder, name))
        except OSError:
            continue
        if head and not said:
            said = head[0].partition(" crashed. ")[2] or head[0]
    return said.strip()[:500]
def stop():
    for _, pid, _ in running.values():
        try:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        except OSError:
            pass
    os._exit(0)
SERVER = os.getpid()
running = {}
pending = b""
while True:
    # the process that asks is gone (killed: its end of our input may live on in a process it forked):
    # this server and its probes end now, not at their alarm
    if os.getppid() != PARENT:
        stop()
    try:
        ready, _, _ = select.select([0, *running], [], [], 0.25)
    except InterruptedError:
        continue
    for fd in ready:
        if fd != 0:
            data = os.read(fd, 1 << 16)
            if data:
                running[fd][2].append(data)
            else:
                finish(fd)
            continue
        data = os.read(0, 1 << 16)
        if not data:  # (our input ended: nobody reads the answers)
            stop()
        pending += data
        while b"\n" in pending:
            line, pending = pending.split(b"\n", 1)
            try:
                start(line)
            except OSError as exc:  # (no process can be forked now)
                tag = json.loads(line)[0]
                answer = [tag, 5, f"cannot start a probe process: {exc}", [], []]
                os.write(1, (json.dumps(answer) + "\n").encode())
"""
