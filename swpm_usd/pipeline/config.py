"""Reading ``pipeline.yaml``: YAML with positions, JSON Schema validation, every error at once.

Each problem is reported as ``FILE:LINE:COL: $.json.path: message``: the config's path as the caller gave
it (``configs/pipeline.yaml`` on the command line), and the line and column of the offending node, 1-based,
so an editor (or a terminal) can jump to it from any folder.
"""

from __future__ import annotations

import datetime
import errno
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jsonschema
import yaml

from ..errors import SwpmError
from .schema import load_schema


class ConfigError(SwpmError):
    """The pipeline configuration is invalid; ``problems`` lists every located message. ``code``:
    ``CONFIG_INVALID``, or ``INPUT_NOT_FOUND`` / ``INPUT_UNREADABLE`` for a config file that does not read,
    ``OUTPUT_UNWRITABLE`` for an ``output.dir`` that cannot be made or written in."""

    code = "CONFIG_INVALID"

    def __init__(self, problems: list[str], *, code: str | None = None) -> None:
        self.problems = problems
        if code is not None:
            self.code = code
        super().__init__("\n".join(problems))


@dataclass
class Config:
    path: Path
    data: dict[str, Any]
    marks: dict[tuple, tuple[int, int]] = field(default_factory=dict)
    #: the text of each unquoted scalar that YAML read as something other than a string (``1e5``, ``yes``,
    #: ``2024-01-01``), by JSON path: an error on a field the schema types as a string quotes it
    plain_scalars: dict[tuple, str] = field(default_factory=dict)
    #: the config's path as the caller gave it, which its problems name (``path`` is resolved; "": it)
    shown: str = ""

    @property
    def base(self) -> Path:
        return self.path.parent

    def where(self, json_path: tuple) -> str:
        line, col = self.marks.get(json_path, self.marks.get((), (1, 1)))
        return f"{self.shown or self.path}:{line}:{col}: {format_path(json_path)}"


def format_path(parts: tuple) -> str:
    out = "$"
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else f".{p}"
    return out


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader, plus YAML 1.2's floats without a dot (``1e-3``, ``2E6``: strings in YAML 1.1)."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?[0-9]+(?:\.[0-9]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def _scalar(node: yaml.Node) -> Any:
    """A scalar node's value (an empty one, as in ``rules:``, is null), via the loader's constructor."""
    return _Loader("").construct_object(node, deep=True)


def _to_python(
    node: yaml.Node,
    path: tuple,
    marks: dict,
    problems: list[str],
    name: str,
    plain: dict[tuple, str] | None = None,
    keys: list[str] | None = None,
) -> Any:
    """Convert a composed YAML node tree to Python values, recording each node's (line, col), and in
    ``plain`` the text of each unquoted scalar read as other than a string; a key given twice in one mapping
    is a problem (located at its second occurrence), and in ``keys`` an unquoted key read as other than the
    string written (``on``, ``1``: a key is a string in JSON and in a prim's customData, as a tag's are)."""
    marks[path] = (node.start_mark.line + 1, node.start_mark.column + 1)
    if isinstance(node, yaml.MappingNode):
        out = {}
        first_line: dict[Any, int] = {}
        for key_node, value_node in node.value:
            key = _scalar(key_node) if isinstance(key_node, yaml.ScalarNode) else repr(key_node.value)
            read = key
            if not isinstance(key, (str, int, float, bool)) and key is not None:
                key = str(key)
            line, col = key_node.start_mark.line + 1, key_node.start_mark.column + 1
            plain_key = isinstance(key_node, yaml.ScalarNode) and key_node.style is None
            if keys is not None and plain_key and key != key_node.value:
                keys.append(
                    f"{name}:{line}:{col}: {format_path((*path, key_node.value))}: key "
                    f"{_quote_hint((), key_node.value, read)}"
                )
            if key in first_line:
                problems.append(
                    f"{name}:{line}:{col}: {format_path((*path, key))}: duplicate key "
                    f"(first given on line {first_line[key]})"
                )
                continue
            first_line[key] = line
            out[key] = _to_python(value_node, (*path, key), marks, problems, name, plain, keys)
            # a wrong key is best pointed at by the key itself
            marks.setdefault((*path, key, "<key>"), (line, col))
        return out
    if isinstance(node, yaml.SequenceNode):
        return [
            _to_python(v, (*path, i), marks, problems, name, plain, keys) for i, v in enumerate(node.value)
        ]
    value = _scalar(node)
    if plain is not None and node.style is None and node.value and not isinstance(value, str):
        plain[path] = node.value
    return value


def _yaml_hint(exc: yaml.YAMLError) -> str:
    """What a YAML error's words mean in a config, for the two a first config meets: ``glob: *.obj``
    unquoted (a ``*`` starts a YAML alias: it said "expected alphabetic or numeric character, but found
    '.'") and a tab in the indentation ("found character '\\t' that cannot start any token")."""
    context, problem = getattr(exc, "context", None) or "", getattr(exc, "problem", None) or ""
    if context == "while scanning an alias" or problem.startswith("found undefined alias"):
        return '; a value starting with * is a YAML alias: quote it, as glob: "*.obj"'
    if "'\\t'" in problem:
        return "; YAML indents with spaces, not tabs"
    return ""


def _mesh_given(path: Path, shown: str) -> str | None:
    """The problem of a mesh file given as the config, ``swpm-pipeline run spot.obj`` (it said "the
    configuration must be a mapping ..., not a scalar", a .glb "cannot read the file (utf-8 codec ...)", a
    .gltf listed its JSON's keys as unknown): what to run instead. None for any other file."""
    suffix = path.suffix.lower()
    if suffix in (".yaml", ".yml", ".json"):  # (a config's: nothing to import or stat)
        return None
    from ..io import SUPPORTED_SUFFIXES

    if suffix not in SUPPORTED_SUFFIXES or not path.is_file():  # (a missing one: "file not found")
        return None
    if _looks_like_config(path):  # (a config named ``assets.usda`` or ``lods.obj`` was refused as a mesh)
        return None
    return (
        f"{shown}:1:1: $: {shown} is a mesh file ({suffix}), not a pipeline config: swpm-pipeline build "
        f"{shown} shows its LODs, swpm-pipeline encode {shown} -o {path.stem}.swpm writes one; a config is "
        "a YAML file whose assets name the meshes (samples/pipeline.yaml is one)"
    )


#: bytes of a file with a mesh's suffix read to tell a config from a mesh (its first line of content)
_SNIFF_BYTES = 4096


def _looks_like_config(path: Path) -> bool:
    """Whether ``path``'s first line of content (past blank lines, ``#`` comments and YAML's ``---``, ``%``)
    opens with one of a config's top-level keys, then ``:`` (``version: 1``, JSON's ``{"assets": ...``).
    A mesh's does not (``v 1 2 3``, ``ply``, ``#usda 1.0`` then ``def``, glTF's ``{"asset": ...``), nor does
    a binary file's (a NUL byte) or one that cannot be read."""
    try:
        with open(path, "rb") as f:
            head = f.read(_SNIFF_BYTES)
    except OSError:
        return False
    if b"\0" in head:
        return False
    keys = "|".join(re.escape(k) for k in load_schema()["properties"])
    opens = re.compile(rf"""\{{?\s*(["']?)(?:{keys})\1\s*:""")
    for line in head.decode("utf-8", errors="replace").lstrip("\ufeff").splitlines():
        line = line.strip()
        if line.startswith("---"):  # (a document's start, content after it on the line or not)
            line = line[3:].strip()
        if not line or line.startswith(("#", "%")):
            continue
        return opens.match(line) is not None
    return False


def load_config(path: str | Path) -> Config:
    """Parse and validate ``path``; raise :class:`ConfigError` listing every problem."""
    path = Path(path)
    shown = str(path)  # (as given: a problem names the file the user named, not its name alone)
    mesh = _mesh_given(path, shown)
    if mesh:
        raise ConfigError([mesh])
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        if exc.errno not in (errno.ENOENT, errno.ELOOP):
            raise ConfigError(
                [f"{shown}:1:1: $: cannot read the file ({exc})"], code="INPUT_UNREADABLE"
            ) from None
        from ..fileio import missing_file_problem

        # (it said "cannot read the file ([Errno 2] No such file or directory: ...)": Python's words; a link
        # in a loop is named so, as a mesh's is)
        raise ConfigError([f"{shown}:1:1: $: {missing_file_problem(path)}"], code="INPUT_NOT_FOUND") from None
    except (
        UnicodeDecodeError
    ) as exc:  # (it reads: its text is not a config's, as a mesh's would be malformed)
        raise ConfigError([f"{shown}:1:1: $: cannot read the file ({exc})"]) from None
    marks: dict[tuple, tuple[int, int]] = {}
    plain: dict[tuple, str] = {}
    duplicates: list[str] = []
    keys: list[str] = []
    try:
        node = yaml.compose(text, Loader=_Loader)
        data = _to_python(node, (), marks, duplicates, shown, plain, keys) if node is not None else None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line, col = (mark.line + 1, mark.column + 1) if mark else (1, 1)
        problem = getattr(exc, "problem", None) or exc
        raise ConfigError([f"{shown}:{line}:{col}: $: invalid YAML: {problem}{_yaml_hint(exc)}"]) from None
    if duplicates:
        raise ConfigError(duplicates)
    cfg = Config(
        path=path.resolve(),
        data=data if isinstance(data, dict) else {},
        marks=marks,
        plain_scalars=plain,
        shown=shown,
    )
    if data is None:  # (an empty file, or comments alone: it said "must be a mapping" of nothing shown)
        raise ConfigError(
            [f"{shown}:1:1: $: the file holds no configuration; a pipeline config is a mapping with version, "
             "assets and output (samples/pipeline.yaml is one)"]
        )  # fmt: skip
    if not isinstance(data, dict):
        raise ConfigError(
            [f"{shown}:1:1: $: the configuration must be a mapping (version, assets, output), not a "
             f"{'list' if isinstance(data, list) else 'scalar'}"]
        )  # fmt: skip
    validator = jsonschema.Draft202012Validator(load_schema())
    problems = list(keys)
    for err in sorted(validator.iter_errors(data), key=lambda e: tuple(map(str, e.absolute_path))):
        problems.extend(_describe(cfg, err))
    problems.extend(_non_finite_params(cfg))
    for i, source in enumerate(data.get("assets") if isinstance(data.get("assets"), list) else []):
        if isinstance(source, dict) and "stage" in source and "instances" in source:
            # (it was ignored: a stage's assets have the instances its composition counts)
            problems.append(
                f"{cfg.where(('assets', i, 'instances'))}: instances is for glob assets; a stage's Mesh "
                "prims are counted from its composition (instanceable prims, point instancers)"
            )
    names: dict[str, int] = {}
    for i, rule in enumerate(data.get("rules") if isinstance(data.get("rules"), list) else []):
        name = rule.get("name") if isinstance(rule, dict) else None
        if isinstance(name, str) and name in names:
            # (the manifest, the report and --explain name the rule an asset matched: which one was it?)
            first = cfg.marks.get(("rules", names[name], "name"), (1, 1))[0]
            problems.append(
                f"{cfg.where(('rules', i, 'name'))}: duplicate rule name (first given on line {first})"
            )
        elif isinstance(name, str):
            names[name] = i
    out = data.get("output")
    if isinstance(out, dict) and out.get("scene") is True and out.get("usd", False) is not True:
        # (the scene references each asset's layer: without them it was written empty, silently)
        problems.append(
            f"{cfg.where(('output', 'scene'))}: scene: true needs usd: true (scene.usda references each "
            "asset's USD layer)"
        )
    if isinstance(out, dict) and out.get("legacy_layout") is True and out.get("swpm", True) is not True:
        # (the layout of .swpm files the config does not write: it asked for something it would not get)
        problems.append(
            f"{cfg.where(('output', 'legacy_layout'))}: legacy_layout: true needs swpm: true (it is the "
            ".swpm files' layout; USD layers have none)"
        )
    if problems:
        raise ConfigError(sorted(set(problems), key=lambda p: _line_key(p, shown)))
    return cfg


def _non_finite_params(cfg: Config) -> list[str]:
    """A parameter (or ``limits.seconds``) given as ``.nan`` or ``.inf`` (YAML's), which the schema's bounds
    let through (every comparison with NaN is false), or an integer one given as a float (``16.0``, which
    JSON Schema's integer takes and the encoders refuse), so that it fails at its line, not asset by asset at
    build time; and every other problem of a number given a parameter, in one line each
    (:func:`.schema.param_problem`, the command line's ``-p`` check)."""
    sections = [(("defaults",), cfg.data.get("defaults"))]
    rules = cfg.data.get("rules")
    if isinstance(rules, list):
        sections += [(("rules", i), rule) for i, rule in enumerate(rules)]
    from ..encodings import combination_problem
    from .schema import DEFAULT, param_problem

    out = []
    for where, section in sections:
        encoding = DEFAULT if where == ("defaults",) else None  # (a rule without one: an error of its own)
        params = section.get("params") if isinstance(section, dict) else None
        if not isinstance(params, dict):
            continue
        enc = str(section.get("encoding", encoding))
        for name, value in params.items():
            if not _numeric_param(cfg, (*where, "params", name)):
                continue  # (a string's problems, and an unknown name's, are the schema's: _describe)
            # (the check the command line's -p makes, in the same words, and the one line of a number's
            # problem: the schema's errors on it are dropped, _describe)
            problem = param_problem(enc, name, value)
            if problem:
                out.append(f"{cfg.where((*where, 'params', name))}: {problem}")
        problem = combination_problem(enc, params)  # (it passed --dry-run and failed every asset)
        if problem:
            out.append(f"{cfg.where((*where, 'params'))}: {problem}")
    limits = cfg.data.get("limits")
    seconds = limits.get("seconds") if isinstance(limits, dict) else None
    if isinstance(seconds, float) and math.isnan(seconds):  # (NaN passes the schema's bounds; inf: over 1e9)
        out.append(f"{cfg.where(('limits', 'seconds'))}: {seconds} is not a finite number")
    return out


def _numeric_param(cfg: Config, path: tuple) -> bool:
    """Is ``path`` (``defaults.params.NAME``, ``rules[i].params.NAME``) a number (not a boolean) given to a
    parameter of its section's encoding? Its problems are :func:`.schema.param_problem`'s alone, one line
    (``cache_size: 2.5`` was three: not an integer, not of type 'integer', and a bound missed)."""
    from ..encodings import ENCODING_PARAMS
    from .schema import DEFAULT

    if len(path) < 3 or path[-2] != "params" or path[0] not in ("defaults", "rules"):
        return False
    section: Any = cfg.data
    for key in path[:-2]:
        try:
            section = section[key]
        except (KeyError, IndexError, TypeError):
            return False
    if not isinstance(section, dict) or not isinstance(section.get("params"), dict):
        return False
    encoding = section.get("encoding", DEFAULT if path[0] == "defaults" else None)
    value = section["params"].get(path[-1])
    return (
        isinstance(encoding, str)
        and path[-1] in ENCODING_PARAMS.get(encoding, {})
        and isinstance(value, (int, float))
        and not isinstance(value, bool)
    )


def _params_encoding(cfg: Config, path: tuple) -> Any:
    """The encoding whose parameters ``path`` (``defaults.params``, ``rules[i].params``) are: its section's
    ``encoding`` (the defaults' default when the defaults give none), None when the config does not say."""
    from .schema import DEFAULT

    section: Any = cfg.data
    for key in path[:-1]:
        try:
            section = section[key]
        except (KeyError, IndexError, TypeError):
            return None
    default = DEFAULT if path[0] == "defaults" else None
    return section.get("encoding", default) if isinstance(section, dict) else None


def _params_owner(cfg: Config, path: tuple) -> str:
    """Whose parameters ``path`` are, for an unknown key's message: its encoding named (it said "this rule's
    encoding", of the defaults too, and of ``auto``, which takes ``select`` alone)."""
    encoding = _params_encoding(cfg, path)
    if encoding == "auto":  # (it builds every encoding with its defaults)
        return "not a parameter of auto, which takes select alone"
    if not isinstance(encoding, str):
        return "not a parameter of this rule's encoding"
    return f"not a parameter of {encoding}"


def _line_key(msg: str, shown: str) -> tuple[int, int, str]:
    """The line and column of a problem ``FILE:LINE:COL: ...`` of the config ``shown`` (a path may hold
    colons of its own), to sort by."""
    try:
        line, col, _ = msg.removeprefix(f"{shown}:").split(":", 2)
        return int(line), int(col), msg
    except ValueError:
        return 0, 0, msg


def _describe(cfg: Config, err: jsonschema.ValidationError) -> list[str]:
    # descend into combinators to report the precise failure (if/then, allOf)
    if err.context:
        out = []
        for sub in err.context:
            out.extend(_describe(cfg, sub))
        if out and err.validator != "oneOf":
            return out
    path = tuple(err.absolute_path)
    if _numeric_param(cfg, path):
        return []  # (worded once by _non_finite_params, as -p words it)
    if err.validator == "additionalProperties":
        extra = sorted(set(err.instance) - set(err.schema.get("properties", {})))
        msgs = []
        for key in extra:
            where = cfg.marks.get((*path, key, "<key>")) or cfg.marks.get(path, (1, 1))
            hint = ""
            known = list(err.schema.get("properties", {}))
            meant = ""
            if path and path[-1] == "params":
                owner = _params_owner(cfg, path)
                encoding = _params_encoding(cfg, path)
                if isinstance(encoding, str) and encoding != "auto":
                    from ..encodings import ENCODING_PARAMS
                    from ..param_hints import meant_elsewhere, taken_elsewhere

                    # (`mu` under `encoding: vanilla`: the encoding that takes it named)
                    elsewhere = taken_elsewhere(encoding, key) if isinstance(key, str) else ""
                    owner += f"; {elsewhere}" if elsewhere else ""
                    # (`MU` under vanilla: the name meant and who takes it, as -p and build() say)
                    if not elsewhere and encoding in ENCODING_PARAMS:
                        meant = meant_elsewhere(encoding, key)
                hint = f" ({owner})"
                known = _owner_params(cfg, path) or known
            msgs.append(
                f"{cfg.shown or cfg.path}:{where[0]}:{where[1]}: {format_path((*path, key))}: "
                f"unknown key{hint}{_did_you_mean(key, known) or (f'; {meant}' if meant else '')}"
            )
        return msgs
    if err.validator == "oneOf" and path and path[0] == "assets":
        return [f"{cfg.where(path)}: an asset source needs exactly one of 'glob' or 'stage'"]
    if err.validator == "type" and _wants_string(err.validator_value) and path in cfg.plain_scalars:
        return [f"{cfg.where(path)}: {_quote_hint(path, cfg.plain_scalars[path], err.instance)}"]
    if err.validator == "enum" and path in cfg.plain_scalars and _wants_string(err.schema.get("type", "")):
        return []  # (a value YAML reads as no string: the type error says so, with the quotes it needs)
    if err.validator == "type" and err.instance is None:  # `rules:` with nothing after it
        expected = (
            err.validator_value if isinstance(err.validator_value, str) else " or ".join(err.validator_value)
        )
        return [
            f"{cfg.where(path)}: empty value (null); expected {'an' if expected[0] in 'aeiou' else 'a'} "
            f"{expected}"
        ]
    from .schema import worded

    hint = ""
    if err.validator == "enum" and isinstance(err.instance, str):  # (`encoding: vanila`)
        hint = _did_you_mean(err.instance, [v for v in err.validator_value if isinstance(v, str)])
    # (a bound missed: in -p's words, schema.param_problem)
    return [f"{cfg.where(path)}: {worded(err)}{hint}"]


def _did_you_mean(word: Any, known: list[str]) -> str:
    """``; did you mean 'vanilla'?`` for a misspelt key or value (:func:`..param_hints.did_you_mean`), or
    ""."""
    from ..param_hints import did_you_mean

    meant = did_you_mean(word, known)
    return f"; {meant}" if meant else ""


def _owner_params(cfg: Config, path: tuple) -> list[str]:
    """The parameter names of the encoding whose ``params`` ``path`` is (none known: [])."""
    from ..encodings import ENCODING_PARAMS

    encoding = _params_encoding(cfg, path)
    return list(ENCODING_PARAMS.get(encoding, ())) if isinstance(encoding, str) else []


def _wants_string(expected: str | list[str]) -> bool:
    return expected == "string" or (isinstance(expected, list) and "string" in expected)


def _quote_hint(path: tuple, text: str, value: Any) -> str:
    """The problem of an unquoted ``text`` that YAML read as ``value`` (not a string) where the schema wants
    a string: what YAML made of it, and the line quoted."""
    if isinstance(value, bool):
        read = f"a boolean ({str(value).lower()})"
    elif isinstance(value, (int, float)):
        read = f"a number ({value!r})"
    elif isinstance(value, datetime.datetime):
        read = "a date and time"
    elif isinstance(value, datetime.date):
        read = "a date"
    elif value is None:
        read = "null"
    else:
        read = type(value).__name__
    key = f"{path[-1]}: " if path and isinstance(path[-1], str) else ""
    return (
        f"{text} is read by YAML as {read}, not a string; quote it to keep it as written: "
        f"{key}{json.dumps(text)}"
    )
