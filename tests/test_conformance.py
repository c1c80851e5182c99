"""The conformance vectors: checked in == generator output, manifest schema, every vector passes."""

from __future__ import annotations

import json
import re
from pathlib import Path

import jsonschema
import pytest

from swpm_usd.format.vectors import build_all, run_conformance

ROOT = Path(__file__).resolve().parents[1]
VECTORS = ROOT / "spec" / "vectors"
SCHEMA = json.loads((ROOT / "spec" / "manifest.schema.json").read_text())


def test_vectors_are_the_generator_output() -> None:
    built = build_all()
    on_disk = {str(p.relative_to(VECTORS)): p.read_bytes() for p in VECTORS.rglob("*") if p.is_file()}
    assert sorted(on_disk) == sorted(built)
    for name, data in built.items():
        assert on_disk[name] == data, f"{name} differs: run python -m swpm_usd.format.vectors spec/vectors"


def test_manifest_and_expected_results_follow_the_schema() -> None:
    manifest = json.loads((VECTORS / "manifest.json").read_text())
    jsonschema.validate(manifest, SCHEMA)
    expected_schema = {**SCHEMA["$defs"]["expected"], "$defs": SCHEMA["$defs"]}
    names = {v["name"] for v in manifest["vectors"]}
    prefix_schema = {**SCHEMA["$defs"]["prefix"], "$defs": SCHEMA["$defs"]}
    ranges_schema = {**SCHEMA["$defs"]["ranges"], "$defs": SCHEMA["$defs"]}
    for v in manifest["vectors"]:
        exp = json.loads((VECTORS / v["expected"]).read_text())
        jsonschema.validate(exp, expected_schema)
        assert exp["valid"] == v["valid"]
        for case in v.get("prefixes", []):
            pexp = json.loads((VECTORS / case["expected"]).read_text())
            jsonschema.validate(pexp, prefix_schema)
            assert pexp["length"] == case["length"]
            # a TOO_SHORT problem gives need > n, and only it gives need
            assert all(("need" in q) == (q["code"] == "SWPM_PREFIX_TOO_SHORT") for q in pexp["problems"])
            assert all(q["need"] > case["length"] for q in pexp["problems"] if "need" in q)
        for case in v.get("ranges", []):
            rexp = json.loads((VECTORS / case["expected"]).read_text())
            jsonschema.validate(rexp, ranges_schema)
            assert rexp["ranges"] == case["ranges"]
            # a NOT_HELD problem gives its range, the offset its first byte not held; only it gives one
            for q in rexp["problems"]:
                assert ("need" in q) == ("need_start" in q) == (q["code"] == "SWPM_RANGES_NOT_HELD")
                if "need" in q:
                    assert q["need_start"] <= q["offset"] < q["need"]
                    assert not any(o <= q["offset"] < o + n for o, n in case["ranges"])
    for need in (
        "truncated-header",
        "truncated-chunk-table",
        "bad-magic",
        "unknown-major-version",
        "crc-mismatch",
        "chunk-past-end",
        "overlapping-chunks",
        "unknown-critical-chunk",
        "window-outside-pool",
        "index-above-vertex-count",
        "non-monotone-records",
        "huge-record-count",
        "minimal-vanilla",
        "vanilla-u32",
        "sliding-window",
        "skip-strip-list",
        "attributes",
        "single-triangle",
        "unknown-ancillary-chunk",
        "mixed",
        "mixed-change-offset-out-of-range",
        "mixed-level-outside-list",
        "skip-binned-not-last",
        "skip-collapsed-list-differs",
        "skip-triangle-count",
        # the cases the audit of a second reader found open, settled in format.md 2.3, 3.3, 3.4, 3.7 and 5
        "rcnt-count-and-change-counts",
        "vanilla-lods-row0-not-index-count",
        "vert-stride-not-element-multiple",
        "vert-attribute-count-too-large",
        "duplicate-meta-misplaced",
        "unknown-ancillary-before-smap",
        "bad-chunk-type",
        "skip-kept-above-vertex-count",
        "skip-index-past-level-table",
        # settled later: format.md 2.2 (padding before a chunk past the end), 2.3 (a trailing duplicate),
        # 3.6 (a slot listed twice)
        "chunk-moved-past-end",
        "duplicate-vert-trailing",
        "record-changes-slot-twice",
        "attributes-32bit",  # usd.md "Attribute values"
        # found reading the spec as a second implementer: format.md 5 (skip-strip stage (a)), 4 (SMAP), 1
        "skip-collapsed-start-not-index-start",
        "truncated-inside-vert",  # format.md 1: the end of the file
        "gap-nonzero-and-crc-mismatch",  # format.md 5 step 2: padding does not stop the CRC check
        "header-size-past-file-size",  # format.md 2.1: header_size against the file's length
        "smap-17-ranges",  # format.md 4: the order of the SMAP checks
        "smap-range-in-trailing-bytes",  # format.md 4, 5: the file as read
        "smap-empty-index-hull",  # format.md 4: an empty window adds nothing to the INDX hull
        # found by a blind reader of the spec (format.md 2.1-2.3, 3.1-3.8, 4, 5): its guesses and the rules
        # no vector checked
        "header-size-below-64",
        "table-too-large",
        "two-encodings-and-duplicate",
        "chunk-misaligned",
        "chunks-out-of-order",
        "chunk-missing",
        "chunk-not-allowed",
        "chunk-bad-flags",
        "lods-empty",
        "lods-row0-not-vertex-count",
        "window-count-mismatch",
        "vanilla-binned-vertex-left",
        "meta-encoding-differs",
        "meta-params-not-object",  # format.md 3.1: a bad params stops the encoding's checks
        "skip-counts-and-level-table",
        "mixed-two-bad-level-arrays",
        "mixed-removes-too-many",
        "reserved-fields-nonzero",
        "vert-nonfinite-point",
        "skip-list-restart-below-vertex-count",
        "smap-hull-split-across-ranges",
        # a strips' restart index is all ones of idx (format.md 3.5, 3.7); an older u32 file's 0xFFFF is valid
        "sliding-window-strips-u32",
        "sliding-window-strips-u32-restart-ffff",
        "skip-strip-strip-u32",
    ):
        assert need in names


def _cited_vectors(text: str) -> set[str]:
    """The vector names a spec text cites: every name of "vector `a`" or "vectors `a`, `b` and `c`" (or
    "prefix case(s)", format.md 4.1, "range case(s)", 4.2), a line break allowed anywhere between the
    words."""
    cites = r"\b(?:vector|(?:prefix|range)\s+case)s?\s+(`[^`]+`(?:(?:,\s*|\s+and\s+)`[^`]+`)*)"
    runs = re.findall(cites, text, re.I)
    return {name for run in runs for name in re.findall(r"`([^`]+)`", run)}


def test_cited_vectors_reads_lists_and_line_breaks() -> None:
    text = "(vector\n   `a-b`), vectors `c`, `d-e`\nand `f`; the vectors `g`; see `h`, vector `i`,\n`j`"
    assert _cited_vectors(text) == {"a-b", "c", "d-e", "f", "g", "i", "j"}
    assert _cited_vectors("prefix cases `k`, `l` and\n`m`; prefix\ncase `n`") == {"k", "l", "m", "n"}
    assert _cited_vectors("range cases `o` and `p`; range\ncase `q`") == {"o", "p", "q"}


def test_every_vector_the_spec_cites_exists_and_every_code_is_exercised() -> None:
    """A vector named in format.md is in the manifest, and every code of errors.md that a file can cause is
    expected by some vector (SWPM_IO_ERROR, _INDEX_WIDTH, _ENCODING_UNAVAILABLE and _BUFFERS_REJECTED are not
    problems of a file's bytes; SWPM_PREFIX_TOO_SHORT and _NOT_STREAMABLE, a prefix reader's, format.md 4.1,
    are expected by the prefix cases, SWPM_RANGES_NOT_HELD, a range reader's, 4.2, by the range cases).
    A name the spec cites may be a vector's, a prefix case's or a range case's."""
    spec = (ROOT / "spec" / "format.md").read_text()
    vectors = json.loads((VECTORS / "manifest.json").read_text())["vectors"]
    names = {v["name"] for v in vectors} | {
        c["name"] for v in vectors for key in ("prefixes", "ranges") for c in v.get(key, [])
    }
    cited = _cited_vectors(spec)
    assert cited and cited <= names, sorted(cited - names)
    codes = set(re.findall(r"^\| `(SWPM_[A-Z0-9_]+)`", (ROOT / "spec" / "errors.md").read_text(), re.M))
    seen = set()
    for path in VECTORS.glob("*/*.json"):
        seen |= {p["code"] for p in json.loads(path.read_text())["problems"]}
    not_of_bytes = {
        "SWPM_IO_ERROR",
        "SWPM_INDEX_WIDTH",
        "SWPM_ENCODING_UNAVAILABLE",
        "SWPM_BUFFERS_REJECTED",
    }
    assert not_of_bytes < codes, sorted(not_of_bytes - codes)  # errors.md's table was read
    assert sorted(codes - not_of_bytes - seen) == []


@pytest.mark.parametrize("outcome", run_conformance(VECTORS), ids=lambda o: o.name)
def test_vector(outcome) -> None:  # noqa: ANN001
    assert outcome.passed, outcome.detail


def test_worked_example_is_the_minimal_vector() -> None:
    spec = (ROOT / "spec" / "format.md").read_text()
    dump = (VECTORS / "minimal-vanilla.hex").read_text()
    assert dump in spec
    assert f"{(VECTORS / 'valid' / 'minimal-vanilla.swpm').stat().st_size} bytes" in spec


def _copy_vectors(tmp_path: Path, edit_entry=None, expected: dict | None = None) -> Path:  # noqa: ANN001
    """A copy of the first valid vector (manifest, file, expected result), edited."""
    manifest = json.loads((VECTORS / "manifest.json").read_text())
    entry = next(v for v in manifest["vectors"] if v["valid"])
    entry.pop("prefixes")  # (the whole-file verdict only; test_a_prefix_case_passes_only_on_its_verdict)
    entry.pop("ranges")
    for key in ("file", "expected"):
        (tmp_path / entry[key]).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / entry[key]).write_bytes((VECTORS / entry[key]).read_bytes())
    if expected is not None:
        (tmp_path / entry["expected"]).write_text(json.dumps(expected))
    if edit_entry is not None:
        edit_entry(entry, tmp_path)
    (tmp_path / "manifest.json").write_text(json.dumps({**manifest, "vectors": [entry]}))
    return tmp_path


@pytest.mark.parametrize(
    ("case", "detail"),
    [
        ("empty expected", "the expected result has no 'valid'"),
        ("missing file", "differs in problems, summary, valid"),
        ("manifest says invalid", "the manifest says valid false, the expected result true"),
        ("file changed", "sha256 of valid/"),
        ("summary dropped", "differs in summary"),
    ],
)
def test_a_vector_passes_only_on_the_whole_expected_result(tmp_path: Path, case: str, detail: str) -> None:
    """The runner compared only the keys the expected result happened to hold and ignored the manifest's
    valid and sha256: an expected result of {} passed any vector, even one whose file is missing."""

    def edit(entry: dict, root: Path) -> None:
        if case == "missing file":
            (root / entry["file"]).unlink()
        elif case == "manifest says invalid":
            entry["valid"] = False
        elif case == "file changed":  # (the file as generated, the manifest's digest of another)
            entry["sha256"] = "0" * 64

    expected = None
    if case == "empty expected":
        expected = {}
    elif case == "summary dropped":  # (a valid file's expected result holds its summary: spec/format.md)
        entry = next(v for v in json.loads((VECTORS / "manifest.json").read_text())["vectors"] if v["valid"])
        expected = json.loads((VECTORS / entry["expected"]).read_text())
        del expected["summary"]
    root = _copy_vectors(tmp_path, edit, expected)
    (outcome,) = run_conformance(root)
    assert not outcome.passed and detail in outcome.detail, outcome.detail
    (intact,) = run_conformance(_copy_vectors(tmp_path / "intact"))
    assert intact.passed, intact.detail


@pytest.mark.parametrize(
    ("edit", "detail"),
    [
        (lambda e: e.update(finest_drawable=0), "differs in finest_drawable"),
        (lambda e: e["problems"][0].update(need=e["problems"][0]["need"] + 1), "differs in problems"),
        (lambda e: e.pop("opened"), "differs in opened"),
        (lambda e: e.update(needed=[620, 609]), "differs in needed"),
    ],
)
def test_a_prefix_case_passes_only_on_its_verdict(tmp_path: Path, edit, detail: str) -> None:  # noqa: ANN001
    """Each prefix case of the manifest is checked against its own expected result (format.md 4.1)."""
    manifest = json.loads((VECTORS / "manifest.json").read_text())
    entry = next(v for v in manifest["vectors"] if v["name"] == "minimal-vanilla")
    entry.pop("ranges")  # (test_a_range_case_passes_only_on_its_verdict)
    short = next(c for c in entry["prefixes"] if c["name"] == "minimal-vanilla-at-records-minus-1")
    opened = next(c for c in entry["prefixes"] if c["name"] == "minimal-vanilla-mid-record")
    entry["prefixes"] = [short if "need" in detail or "problems" in detail else opened]
    for rel in (entry["file"], entry["expected"], entry["prefixes"][0]["expected"]):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes((VECTORS / rel).read_bytes())
    (tmp_path / "manifest.json").write_text(json.dumps({**manifest, "vectors": [entry]}))
    whole, case = run_conformance(tmp_path)
    assert whole.passed and case.passed, case.detail
    exp_path = tmp_path / entry["prefixes"][0]["expected"]
    exp = json.loads(exp_path.read_text())
    edit(exp)
    exp_path.write_text(json.dumps(exp))
    whole, case = run_conformance(tmp_path)
    assert whole.passed and case.name == f"minimal-vanilla/{entry['prefixes'][0]['name']}"
    assert not case.passed and detail in case.detail, case.detail


@pytest.mark.parametrize(
    ("edit", "detail"),
    [
        (lambda e: e.update(drawable_lods=[0, 1]), "differs in drawable_lods"),
        (lambda e: e["drawable"].pop("1"), "differs in drawable"),
        (lambda e: e["needed"][1].pop(1), "differs in needed"),
        (lambda e: e.update(opened=False), "differs in opened"),
    ],
)
def test_a_range_case_passes_only_on_its_verdict(tmp_path: Path, edit, detail: str) -> None:  # noqa: ANN001
    """Each range case of the manifest is checked against its own expected result (format.md 4.2)."""
    manifest = json.loads((VECTORS / "manifest.json").read_text())
    entry = next(v for v in manifest["vectors"] if v["name"] == "minimal-vanilla")
    entry.pop("prefixes")
    entry["ranges"] = [c for c in entry["ranges"] if c["name"] == "minimal-vanilla-unsorted-overlapping"]
    for rel in (entry["file"], entry["expected"], entry["ranges"][0]["expected"]):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes((VECTORS / rel).read_bytes())
    (tmp_path / "manifest.json").write_text(json.dumps({**manifest, "vectors": [entry]}))
    whole, case = run_conformance(tmp_path)
    assert whole.passed and case.passed, case.detail
    exp_path = tmp_path / entry["ranges"][0]["expected"]
    exp = json.loads(exp_path.read_text())
    edit(exp)
    exp_path.write_text(json.dumps(exp))
    whole, case = run_conformance(tmp_path)
    assert whole.passed and case.name == "minimal-vanilla/minimal-vanilla-unsorted-overlapping"
    assert not case.passed and detail in case.detail, case.detail
