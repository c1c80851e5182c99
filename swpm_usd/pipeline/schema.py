"""The JSON Schema of ``pipeline.yaml``, generated from the encoders' own parameter tables.

``pipeline/pipeline.schema.json`` is this function's output, checked in; a test fails when they differ
(``python -m swpm_usd.pipeline.schema > pipeline/pipeline.schema.json`` regenerates it). A rule's
``params`` may only name parameters of the rule's ``encoding``; ``auto`` takes ``select`` alone (what it ranks
the candidates by: :data:`.auto.AUTO_SELECT`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .auto import AUTO_SELECT

#: the encoding of ``defaults`` without one (:func:`.assets.match_rule`)
DEFAULT = "sliding-window"
SCHEMA_PATH = Path(__file__).resolve().parents[2] / "pipeline" / "pipeline.schema.json"
PACKAGED_SCHEMA = Path(__file__).resolve().parent / "pipeline.schema.json"


def _param_schema(value: Any, name: str = "", encoding: str = "") -> dict[str, Any]:
    from ..build import MAX_CACHE_SIZE, MAX_QUADRIC_WEIGHT
    from ..encodings import MAX_ORDER_PASSES, MAX_ORDER_REACH, MAX_STRIP_WINDOW, PRIMITIVES

    # the bounds build() and the encoders check, so a config fails at its line, not asset by asset
    if name == "cache_size":
        least = 3 if encoding == "sliding-window" else 1
        return {"type": "integer", "minimum": least, "maximum": MAX_CACHE_SIZE}
    if name == "builder":
        return {"type": "string", "enum": ["topology", "forsyth"]}
    if name == "primitive":
        return {"type": "string", "enum": list(PRIMITIVES)}
    if name in ("mu", "degenerate_threshold", "level_threshold"):
        return {"type": "number", "minimum": 0, "exclusiveMaximum": 1}
    if name in ("tolerance", "swap_max_deviation"):
        return {"type": "number", "minimum": 0}
    if name == "target_slack":
        return {"type": ["number", "null"], "minimum": 0}
    if name == "error_bound":
        return {"type": ["number", "null"], "exclusiveMinimum": 0}
    if name == "inner_vertices":
        return {"type": "integer", "minimum": 1}
    if name == "absorb_rounds":
        return {"type": "integer", "minimum": 0}
    if name == "order_passes":  # null: the encoder's default
        return {"type": ["integer", "null"], "minimum": 0, "maximum": MAX_ORDER_PASSES}
    if name == "order_reach":
        return {"type": "integer", "minimum": 1, "maximum": MAX_ORDER_REACH}
    if name == "strip_window":
        return {"type": "integer", "minimum": 1, "maximum": MAX_STRIP_WINDOW}
    if name in ("boundary_weight", "seam_weight"):
        return {"type": "number", "minimum": 0, "maximum": MAX_QUADRIC_WEIGHT}
    if value is None:  # an optional number: None leaves the choice to the encoder
        return {"type": ["number", "null"]}
    if isinstance(value, bool):
        return {"type": "boolean"}
    if isinstance(value, int):
        return {"type": "integer"}
    if isinstance(value, float):
        return {"type": "number"}
    if isinstance(value, str):
        return {"type": "string"}
    return {}


def _described(name: str, value: Any, encoding: str) -> dict[str, Any]:
    """A parameter's schema with what it does and its default, for an editor that completes a config from
    the schema (the lines of ``encode --help``, :data:`..encodings.PARAM_HELP`)."""
    from ..encodings import PARAM_HELP

    return {**_param_schema(value, name, encoding), "description": PARAM_HELP[name], "default": value}


def param_problem(encoding: str, name: str, value: Any) -> str | None:
    """What is wrong with ``value`` for the parameter ``name`` of ``encoding``, or None: the one check of a
    parameter's value, the command line's ``-p`` (:func:`..format.cli._encoding_and_params`) and a config's
    ``params`` (:func:`.config.load_config`) alike, in the words of the config's JSON Schema validation (its
    messages on the parameter's own schema), after what JSON Schema lets through (:func:`beyond_schema`):
    one problem a value, ``cache_size: 2.5`` an integer wanted, not also a bound missed."""
    import jsonschema

    from ..encodings import ENCODING_PARAMS

    schema = _param_schema(ENCODING_PARAMS[encoding][name], name, encoding)
    beyond = beyond_schema(schema, value)
    if beyond is not None:
        return beyond
    error = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(schema).iter_errors(value))
    return worded(error) if error is not None else None


_BOUNDS = ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum")


def worded(error: Any) -> str:
    """The message of a JSON Schema ``error`` (a ``jsonschema.ValidationError``) as a user reads it: a bound
    missed is worded by the interval of its schema, ``must be in [0, 1), got 2`` (jsonschema's own, ``2 is
    greater than or equal to the maximum of 1``, names one end, and in words); any other, jsonschema's. The
    command line's ``-p`` (:func:`param_problem`) and a config (:func:`.config.load_config`) both word theirs
    so."""
    if error.validator not in _BOUNDS or not isinstance(error.schema, dict):
        return str(error.message)
    bounds = error.schema
    # (a whole bound shown whole: 1e6, MAX_QUADRIC_WEIGHT, as 1000000, not 1000000.0)
    low, above, high, below = (
        int(x) if isinstance(x, float) and x.is_integer() else x
        for x in map(bounds.get, ("minimum", "exclusiveMinimum", "maximum", "exclusiveMaximum"))
    )
    got = error.instance
    if (low is not None or above is not None) and (high is not None or below is not None):
        lower = f"[{low}" if low is not None else f"({above}"
        upper = f"{high}]" if high is not None else f"{below})"
        return f"must be in {lower}, {upper}, got {got}"
    if low is not None:
        return f"must be at least {low}, got {got}"
    if above is not None:
        return f"must be greater than {above}, got {got}"
    return (
        f"must be at most {high}, got {got}" if high is not None else f"must be less than {below}, got {got}"
    )


def beyond_schema(schema: dict[str, Any], value: Any) -> str | None:
    """What is wrong with ``value`` by a parameter's ``schema`` that JSON Schema lets through, or None: a
    number not finite (every bound's comparison with NaN is false; json and YAML read both) or a float where
    an integer is wanted (JSON Schema's integer takes ``16.0``, the encoders refuse it; ``2.5`` is worded
    alike, the one problem of that value: not also a bound it misses)."""
    import math

    if isinstance(value, float) and not math.isfinite(value):
        return f"{value} is not a finite number"
    if isinstance(value, float) and "integer" in str(schema.get("type")):
        return f"must be an integer, got {value}"
    return None


def real_valued(name: str, default: Any) -> bool:
    """Is the encoding parameter ``name`` (default ``default``) a real number in the config's schema: a float
    default, or an optional number (``None`` leaves the choice to the encoder)?"""
    kind = _param_schema(default, name).get("type")
    return kind == "number" or (isinstance(kind, list) and "number" in kind)


def build_schema() -> dict[str, Any]:
    from ..encodings import ENCODING_PARAMS

    encodings = sorted(ENCODING_PARAMS)
    range_ = {
        "type": "object",
        "additionalProperties": False,
        "properties": {"min": {"type": "number", "minimum": 0}, "max": {"type": "number", "minimum": 0}},
    }
    match = {
        "type": "object",
        "additionalProperties": False,
        "description": "Every given condition must hold; an absent match matches every asset.",
        "properties": {
            "path": {"type": "string", "description": "glob on the asset's path relative to the config"},
            "prim": {"type": "string", "description": "glob on the USD prim path (stage assets)"},
            "triangles": range_,
            "instances": range_,
            "tag": {
                "type": "object",
                "description": "USD customData key -> value the prim must carry (stage assets)",
                "additionalProperties": {"type": ["string", "number", "boolean"]},
            },
        },
    }
    by_encoding = []
    params_of = {}
    for enc in encodings:
        defaults = ENCODING_PARAMS[enc]
        params_of[enc] = {
            "properties": {
                "params": {
                    "type": "object",
                    "additionalProperties": False,
                    "properties": {k: _described(k, v, enc) for k, v in sorted(defaults.items())},
                }
            }
        }
        by_encoding.append(
            {
                "if": {"properties": {"encoding": {"const": enc}}, "required": ["encoding"]},
                "then": params_of[enc],
            }
        )
    by_encoding.append(
        {
            "if": {"properties": {"encoding": {"const": "auto"}}, "required": ["encoding"]},
            "then": {
                "properties": {
                    "params": {
                        "type": "object",
                        "additionalProperties": False,
                        "properties": {
                            "select": {
                                "enum": list(AUTO_SELECT),
                                "default": AUTO_SELECT[0],
                                "description": "rank the candidates within the budgets by their ACMR at half "
                                "the triangles, or by the cache misses they draw at equal error",
                            }
                        },
                    }
                }
            },
        }
    )
    treatment = {
        "encoding": {"enum": [*encodings, "auto"]},
        "params": {"type": "object"},
    }
    rule = {
        "type": "object",
        "additionalProperties": False,
        "required": ["name", "encoding"],
        "properties": {"name": {"type": "string", "minLength": 1}, "match": match, **treatment},
        "allOf": by_encoding,
    }
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://swpm-usd.invalid/pipeline.schema.json",
        "title": "swpm-usd pipeline configuration",
        "type": "object",
        "additionalProperties": False,
        "required": ["version", "assets", "output"],
        "properties": {
            "version": {"const": 1},
            "assets": {
                "type": "array",
                "minItems": 1,
                "items": {
                    "type": "object",
                    "additionalProperties": False,
                    "oneOf": [{"required": ["glob"]}, {"required": ["stage"]}],
                    "properties": {
                        "glob": {"type": "string", "description": "mesh files, relative to the config"},
                        "stage": {"type": "string", "description": "a USD stage: its Mesh prims are assets"},
                        "instances": {
                            "type": "integer",
                            "minimum": 1,
                            "description": "for glob assets (a stage counts its own: an error beside stage)",
                        },
                    },
                },
            },
            "output": {
                "type": "object",
                "additionalProperties": False,
                "required": ["dir"],
                "properties": {
                    "dir": {
                        "type": "string",
                        "description": "relative to the config; the run writes <name>.swpm, <name>.usdc, "
                        "scene.usda, manifest.json and report.html there, and refuses to start when one "
                        "of them would overwrite an input (a matched file, a stage or a layer it uses, the "
                        "config); a glob never takes a file in it or below it as an asset (an output.dir "
                        "that holds the config: the outputs its manifest records)",
                    },
                    "swpm": {"type": "boolean", "default": True},
                    "legacy_layout": {
                        "type": "boolean",
                        "default": False,
                        "description": "write each .swpm as a reader before 0.9.0 accepts it: one integer "
                        "width for every array, never the OFFSET32 feature bit such a reader refuses; a "
                        "file whose tables need u32 (a sliding-window pool longer than 65,535 indices) is "
                        "then u32 throughout (INDEX32), larger. Flipping it rewrites the .swpm outputs on "
                        "the next run; the manifest records each one's legacy_layout, index_width and "
                        "offset_width. USD outputs are unaffected",
                    },
                    "usd": {"type": "boolean", "default": False, "description": "per-asset USD layers"},
                    "scene": {
                        "type": "boolean",
                        "default": False,
                        "description": "scene layer of them all (needs usd: true)",
                    },
                    "report": {"type": "boolean", "default": True, "description": "report.html"},
                    "names": {
                        "enum": ["stem", "path"],
                        "default": "stem",
                        "description": "how outputs are named: stem, by the file's stem (rock.swpm; two "
                        "files of one stem in different folders are an error); path, by the file's path "
                        "under the fixed folder its glob starts from, without its suffix, folders joined "
                        "by -- (library/**/*.gltf: library/props/chair/scene.gltf writes "
                        "props--chair--scene.swpm; a glob without a wildcard, and a stage, start from "
                        "their file's folder). A stage's prims add __<prim> either way. Outputs stay in "
                        "output.dir; flipping it builds each asset again under its new names, the old "
                        "ones left as orphans (prune deletes them)",
                    },
                },
            },
            "defaults": {
                "type": "object",
                "additionalProperties": False,
                "properties": treatment,
                # (without an encoding the defaults build sliding-window: its params are checked as such)
                "allOf": [
                    *by_encoding,
                    {"if": {"not": {"required": ["encoding"]}}, "then": params_of[DEFAULT]},
                ],
            },
            "rules": {"type": "array", "items": rule},
            "streaming": {
                "type": "object",
                "additionalProperties": False,
                "properties": {
                    "order": {"enum": ["coarse-to-fine"]},
                    "coarsest_lod_bytes": {"type": "integer", "minimum": 1},
                    "max_lods": {"type": "integer", "minimum": 1},
                    "min_coarsest_triangles": {"type": "integer", "minimum": 0},
                },
            },
            "budgets": {
                "type": "object",
                "additionalProperties": False,
                "properties": {
                    "global_bytes": {"type": "integer", "minimum": 1},
                    "instance_bytes": {"type": "integer", "minimum": 1},
                    "total_bytes": {"type": "integer", "minimum": 1},
                },
            },
            "limits": {
                "type": "object",
                "additionalProperties": False,
                "properties": {
                    "seconds": {
                        "type": "number",
                        "exclusiveMinimum": 0,
                        "maximum": 1e9,
                        "description": "wall-clock seconds one asset may take: an asset still building then "
                        "has its worker process stopped and fails (the others go on); local executor only",
                    },
                    "max_triangles": {
                        "type": "integer",
                        "minimum": 0,
                        "description": "the most triangles an asset's file may hold (each instance of a glTF "
                        "mesh or USD prototype counted, before cleaning): an asset over it fails, refused "
                        "before its file is read where the format tells the count; the others are built",
                    },
                },
            },
        },
    }


def schema_text() -> str:
    return json.dumps(build_schema(), indent=2, sort_keys=False) + "\n"


def load_schema() -> dict[str, Any]:
    """The checked-in schema (the repository copy when present, else the packaged copy)."""
    for p in (SCHEMA_PATH, PACKAGED_SCHEMA):
        if p.exists():
            return json.loads(p.read_text())
    return build_schema()


if __name__ == "__main__":  # pragma: no cover
    print(schema_text(), end="")
