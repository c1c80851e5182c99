"""The SwpmMeshAPI schema: one table of properties, the three resource files generated from it.

SwpmMeshAPI is a codeless single-apply API schema for ``Mesh`` prims. Every property is ``uniform``,
namespaced ``swpm:`` and named in camelCase after the buffer it stores (``index_pool`` ->
``swpm:indexPool``); see
``spec/usd.md``. ``PROPERTIES`` is the single source of truth: ``python -m swpm_usd.usd.schema`` rewrites
``resources/schema.usda`` (usdGenSchema input, for reference), ``resources/generatedSchema.usda`` and
``resources/plugInfo.json`` (what USD loads), and ``tests/test_usd.py`` checks they are in sync.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

SCHEMA_NAME = "SwpmMeshAPI"
RESOURCES = Path(__file__).resolve().parent / "resources"
#: version of the attribute layout below (bumped on an incompatible change)
FORMAT_VERSION = 1
#: encodings the ``swpm:encoding`` token may name
ENCODING_TOKENS = ("vanilla", "sliding-window", "skip-strip", "mixed")
#: buffers stored as columns of the (R, F) ``swpm:collapseRecords`` table instead of one attribute each
COLLAPSE_PREFIX = "collapse_"
COLLAPSE_FLAT = ("collapse_change_offsets",)


@dataclass(frozen=True)
class Prop:
    """One schema attribute: name, Sdf type name, fallback (usda literal), doc, allowed tokens."""

    name: str
    type: str
    fallback: str
    doc: str
    allowed: tuple[str, ...] = ()


def camel(buffer_name: str) -> str:
    """``index_pool`` -> ``indexPool``: the attribute base name of a buffer."""
    head, *rest = buffer_name.split("_")
    return head + "".join(w[:1].upper() + w[1:] for w in rest)


def attr_name(buffer_name: str) -> str:
    """``index_pool`` -> ``swpm:indexPool``."""
    return "swpm:" + camel(buffer_name)


PROPERTIES: tuple[Prop, ...] = (
    Prop("swpm:formatVersion", "int", "1", "Version of the SwpmMeshAPI attribute layout (currently 1)."),
    Prop(
        "swpm:encoding",
        "token",
        '"vanilla"',
        "The progressive-mesh encoding whose buffers this prim stores.",
        ENCODING_TOKENS,
    ),
    Prop(
        "swpm:indexWidth",
        "int",
        "4",
        "Bytes per index a GPU index buffer needs (2 below 65,536 vertices, every vertex id then below u16's "
        "all ones, the restart index WebGL 2 always applies, while a strips' restart index fits in 16 bits, "
        "0xFFFFFFFF counting as 0xFFFF: a u32 -> u16 copy turns it into u16's all ones; else 4). USD always "
        "stores indices as uint[]; this says how a runtime should upload them.",
    ),
    Prop(
        "swpm:vertexCounts",
        "uint[]",
        "[]",
        "Per LOD (L entries, LOD 0 first): number of vertices LOD k uses; it draws only the prefix "
        "[0, vertexCounts[k]) of points, which are stored in LOD order.",
    ),
    Prop("swpm:triangleCounts", "uint[]", "[]", "Per LOD: visible (non-degenerate) triangles."),
    Prop(
        "swpm:lodErrors",
        "float[]",
        "[]",
        "Per LOD: geometric error in mesh units (finite, non-decreasing), for screen-space selection.",
    ),
    Prop(
        "swpm:params",
        "string",
        '"{}"',
        "The encoder's parameters as a JSON object, under the rules of a .swpm file's META (spec/format.md "
        "3.1: no NaN or infinity, no duplicate key, at most 128 deep); a writer refuses others, a reader "
        "rejects them.",
    ),
    Prop(
        "swpm:attributeNames",
        "token[]",
        "[]",
        "Names of the progressive mesh's per-vertex attributes, in order. normal of 3 components -> normals, "
        "uv of 2 -> primvars:st, color of 3 or 4 -> primvars:displayColor (+ primvars:displayOpacity for 4 "
        "channels), any other name or component count -> primvars:<name> (a color of 1, 2 or 5+ components "
        "-> primvars:color); all vertex interpolation, in LOD order.",
    ),
    Prop(
        "swpm:attributeDtypes",
        "token[]",
        "[]",
        "Numpy dtype of each attribute (parallel to swpm:attributeNames); the float primvar is cast back to "
        "it. Unsigned-integer color components (any component count) are stored normalised to [0, 1] "
        "(value / (2^bits - 1)) and scaled back (exact for 8 and 16 bits; 32-bit values keep 24 significant "
        "bits, see spec/usd.md). Absent: float32.",
    ),
    Prop(
        "swpm:bufferNames",
        "token[]",
        "[]",
        "Names (snake_case, as in the format) of the encoding's buffers, in order. Buffer b is stored in "
        "swpm:<camelCase(b)>, except collapse_* record columns, which are columns of swpm:collapseRecords.",
    ),
    Prop(
        "swpm:bufferDtypes",
        "token[]",
        "[]",
        "Numpy dtype of each buffer (parallel to swpm:bufferNames); the stored array is cast back to it.",
    ),
    Prop(
        "swpm:bufferColumns",
        "uint[]",
        "[]",
        "Row width of each buffer (parallel to swpm:bufferNames): 0 for a 1-D buffer, k for an (n, k) "
        "buffer stored flattened row-major (e.g. 3 for windowRecords).",
    ),
    Prop(
        "swpm:collapseRecordFields",
        "token[]",
        "[]",
        "Column names of swpm:collapseRecords, e.g. [kept, trisRemoved, changeCount, prevChangeCount] "
        "(vanilla) or [kept, binned, changeCount, prevChangeCount] (skip-strip).",
    ),
    Prop(
        "swpm:collapseRecords",
        "uint[]",
        "[]",
        "Collapse record headers, an (R, F) row-major table flattened to R*F entries, F = "
        "len(swpm:collapseRecordFields): one row per record (Forsyth's VanillaCollapseRecord header).",
    ),
    Prop(
        "swpm:collapseChangeOffsets",
        "uint[]",
        "[]",
        "Index-buffer slots each record rewrites, records consecutive (record r owns changeCount[r]).",
    ),
    Prop("swpm:lodRecordCounts", "uint[]", "[]", "Per LOD: collapse records applied to reach LOD k."),
    Prop("swpm:indices", "uint[]", "[]", "vanilla: LOD-0 triangle list, triangles in bin order."),
    Prop(
        "swpm:indexPool",
        "uint[]",
        "[]",
        "sliding-window: the static index pool, triangle lists or (params primitive 'strip') strips.",
    ),
    Prop(
        "swpm:windowRecords",
        "uint[]",
        "[]",
        "sliding-window: per LOD (first index offset, triangle count, vertex count), flattened to 3L "
        "entries (USD has no uint3[]). The window of LOD k is indexPool[first, first + 3 * count) (a "
        "strip pool: windowIndexCounts[k] indices from first).",
    ),
    Prop(
        "swpm:windowIndexCounts",
        "uint[]",
        "[]",
        "sliding-window with params primitive 'strip' only: per LOD, the number of indexPool entries its "
        "window draws as one strip (restart index params restart_index).",
    ),
    Prop("swpm:levelFirstLod", "uint[]", "[]", "skip-strip: first LOD drawn from each level."),
    Prop("swpm:levelIndexStart", "uint[]", "[]", "skip-strip: CSR start of each level in levelIndices."),
    Prop("swpm:levelIndices", "uint[]", "[]", "skip-strip: each level's uncollapsed draw list."),
    Prop("swpm:levelCollapsedStart", "uint[]", "[]", "skip-strip: CSR start of each level's collapsed list."),
    Prop("swpm:levelCollapsedIndices", "uint[]", "[]", "skip-strip: each level's fully collapsed list."),
    Prop("swpm:levelRecordStart", "uint[]", "[]", "skip-strip: range of records of each level."),
    Prop("swpm:levelStaticStart", "uint[]", "[]", "mixed: CSR start of each level's static list."),
    Prop("swpm:levelStaticIndices", "uint[]", "[]", "mixed: each level's static (shared) triangle list."),
    Prop("swpm:levelDynamicStart", "uint[]", "[]", "mixed: CSR start of each level's dynamic lists."),
    Prop("swpm:levelDynamicIndices", "uint[]", "[]", "mixed: each level's uncollapsed dynamic list."),
    Prop(
        "swpm:levelDynamicCollapsedIndices",
        "uint[]",
        "[]",
        "mixed: each level's fully collapsed dynamic list.",
    ),
    Prop(
        "swpm:streamingBands",
        "uint[]",
        "[]",
        "Streaming map of the format, file-independent part: (first LOD, LOD count) per band, flattened; "
        "band b holds the LODs with floor(log2(vertexCounts[0] / vertexCounts[k])) == b, coarse bands "
        "need only a prefix of points.",
    ),
    Prop(
        "swpm:discreteLods",
        "uint[]",
        "[]",
        "Optional: the progressive LOD index of each discrete LOD variant LOD0, LOD1, ... (see spec/usd.md).",
    ),
)

PROPERTY_TYPES: dict[str, str] = {p.name: p.type for p in PROPERTIES}

_DOC = (
    "View-independent progressive mesh buffers on a Mesh prim. points are in LOD order; "
    "faceVertexIndices / faceVertexCounts hold LOD 0 so any USD tool shows the full-detail model."
)


def _quote(doc: str) -> str:
    return '"""' + doc.replace('"""', "'''") + '"""'


def _props_usda(indent: str = "    ") -> str:
    out = []
    for p in PROPERTIES:
        meta = []
        if p.allowed:
            meta.append(f"{indent * 2}allowedTokens = [{', '.join(json.dumps(t) for t in p.allowed)}]")
        meta.append(f"{indent * 2}doc = {_quote(p.doc)}")
        out.append(f"{indent}uniform {p.type} {p.name} = {p.fallback} (\n" + "\n".join(meta) + f"\n{indent})")
    return "\n".join(out)


def generated_schema_usda() -> str:
    """Text of ``generatedSchema.usda`` (what USD reads through plugInfo.json)."""
    return (
        "#usda 1.0\n(\n"
        '    "WARNING: THIS FILE IS GENERATED BY swpm_usd.usd.schema.  DO NOT EDIT."\n)\n\n'
        f'class "{SCHEMA_NAME}" (\n    doc = {_quote(_DOC)}\n)\n{{\n{_props_usda()}\n}}\n'
    )


def schema_usda() -> str:
    """Text of ``schema.usda``: the usdGenSchema input (codeless), kept for reference and other tools."""
    return (
        "#usda 1.0\n(\n"
        '    """SwpmMeshAPI: progressive-mesh buffers on Mesh prims (codeless; generated from '
        'swpm_usd/usd/schema.py)."""\n'
        "    subLayers = [@usd/schema.usda@]\n)\n\n"
        'over "GLOBAL" (\n    customData = {\n        string libraryName = "swpm"\n'
        '        string libraryPath = "."\n        bool skipCodeGeneration = true\n    }\n) {\n}\n\n'
        f'class "{SCHEMA_NAME}" (\n    inherits = </APISchemaBase>\n    doc = {_quote(_DOC)}\n'
        '    customData = {\n        string className = "MeshAPI"\n'
        '        token apiSchemaType = "singleApply"\n'
        '        token[] apiSchemaCanOnlyApplyTo = ["Mesh"]\n    }\n)\n'
        f"{{\n{_props_usda()}\n}}\n"
    )


def plug_info() -> dict:
    """Contents of ``plugInfo.json`` (a resource plugin: Root and ResourcePath are the folder itself)."""
    return {
        "Plugins": [
            {
                "Info": {
                    "Types": {
                        # (no "alias": {"UsdSchemaBase": SCHEMA_NAME}: an alias of the type's own name
                        # made every Usd.Stage.Open raise in a process given the plugin through
                        # PXR_PLUGINPATH_NAME, "There already is a type named 'SwpmMeshAPI'")
                        SCHEMA_NAME: {
                            "apiSchemaCanOnlyApplyTo": ["Mesh"],
                            "autoGenerated": True,
                            "bases": ["UsdAPISchemaBase"],
                            "schemaIdentifier": SCHEMA_NAME,
                            "schemaKind": "singleApplyAPI",
                        }
                    }
                },
                "Name": "swpm",
                "ResourcePath": ".",
                "Root": ".",
                "Type": "resource",
            }
        ]
    }


def resource_texts() -> dict[str, str]:
    """File name -> expected text of every resource file."""
    return {
        "plugInfo.json": json.dumps(plug_info(), indent=4) + "\n",
        "generatedSchema.usda": generated_schema_usda(),
        "schema.usda": schema_usda(),
    }


def write_resources(folder: Path = RESOURCES) -> None:
    """Regenerate the resource files from :data:`PROPERTIES`."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in resource_texts().items():
        (folder / name).write_text(text, encoding="utf-8")


if __name__ == "__main__":
    write_resources()
    print(f"wrote {', '.join(resource_texts())} to {RESOURCES}")
