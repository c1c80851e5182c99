"""The ``META`` chunk: its JSON read with the rules of spec 3.1, and its fields checked.

:func:`parse_meta_json` rejects NaN and Infinity, duplicate keys, numbers that do not fit binary64 and
nesting deeper than ``META_MAX_DEPTH`` (measured first by :func:`_json_depth`, a linear vectorised scan, so
that Python's recursive parser never meets a deep text); :func:`_meta` reports ``SWPM_META_BAD_JSON`` and
``SWPM_META_BAD_FIELD``. Separate from the reader because the writer and the USD layer parse ``META`` with
the same rules without reading a file, and the depth scan is an algorithm of its own.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from . import layout as L
from .errors import Report
from .parsed import _get, _Parsed


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not JSON")


def _finite_float(text: str) -> float:
    """A JSON number with a fraction or exponent; one that rounds to infinity (1e400) is rejected, as
    Infinity is (spec 3.1)."""
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"number {text[:20]}... is too large for binary64")
    return value


def _finite_int(text: str) -> int:
    """A JSON integer, exact; one too large for binary64 is rejected (spec 3.1), before ``int`` could meet
    Python's digit limit for str-to-int conversion (which the environment can lower)."""
    if not math.isfinite(float(text)):
        raise ValueError(f"number {text[:20]}... is too large for binary64")
    return int(text)  # at most 309 digits here, below the lowest digit limit Python allows (640)


def _json_depth(text: str) -> int:
    """How deep arrays and objects nest in ``text`` (outside strings); exact for valid JSON.

    Linear and vectorised over the UTF-8 bytes (the structural characters are ASCII, which never occur
    inside a multi-byte sequence; an unpaired surrogate is encoded as its three bytes). A string runs from a
    quote outside a string to the next quote not escaped, or to the end of the text; a backslash escapes the
    next character inside a string only, so a quote after an odd run of backslashes ends nothing inside a
    string and opens one outside it. Each quote is therefore "toggle" (after an even run) or "set inside"
    (after an odd run): the state after a quote is 1 after the last "set inside" before it, flipped by the
    toggles since. Same answers as a scan of string literals and brackets, valid JSON or not (a closing
    bracket too many makes the depth negative, the deepest point stays the maximum reached).

    The text is scanned :data:`_JSON_BLOCK` bytes at a time, carrying the depth, whether a string is open
    and the parity of the run of backslashes the block starts in: the arrays of a block's quotes and
    backslashes are 8-byte positions (about 48 bytes per byte of a text of quotes), so memory stays a
    block's worth plus the encoded text."""
    data = text.encode("utf-8", "surrogatepass")
    deepest = depth = 0
    inside = False  # a string open at the block's start
    odd = False  # the block starts after an odd run of backslashes
    for i in range(0, len(data), _JSON_BLOCK):
        b = np.frombuffer(data, np.uint8, min(_JSON_BLOCK, len(data) - i), i)
        n = b.size
        # +1 at [ and {, -1 at ] and }, 0 elsewhere: one byte each (not a table lookup: its index is 8 bytes)
        step = ((b == 91) | (b == 123)).view(np.int8) - ((b == 93) | (b == 125)).view(np.int8)
        quotes = np.flatnonzero(b == 34)
        if quotes.size:
            slashes = np.flatnonzero(b == 92)
            after_odd_run = np.zeros(quotes.size, bool)  # the quotes after an odd run of backslashes
            after_odd_run[0] = odd and quotes[0] == 0
            if slashes.size:
                breaks = np.flatnonzero(np.diff(slashes) != 1)
                starts = slashes[np.concatenate(([0], breaks + 1))]
                ends = slashes[np.concatenate((breaks, [slashes.size - 1]))]
                lengths = ends - starts + 1
                if odd and starts[0] == 0:  # (the run goes on from the block before)
                    lengths[0] += 1
                nxt = ends[lengths % 2 == 1] + 1  # after an odd run
                nxt = nxt[nxt < n]
                at = np.searchsorted(quotes, nxt)
                hit = at < quotes.size
                hit[hit] = quotes[at[hit]] == nxt[hit]
                after_odd_run[at[hit]] = True
            toggles = np.cumsum(~after_odd_run)
            last_set = np.maximum.accumulate(np.where(after_odd_run, np.arange(quotes.size), -1))
            since = np.where(last_set >= 0, toggles - toggles[np.maximum(last_set, 0)], toggles)
            in_string = ((since & 1) == 1) ^ np.where(last_set >= 0, True, inside)  # after each quote
            change = np.zeros(n, np.uint8)
            change[quotes] = in_string ^ np.concatenate(([inside], in_string[:-1]))
            state = np.bitwise_xor.accumulate(change).view(bool)
            step[state ^ inside] = 0  # (a bracket is in a string or not after it)
            inside = bool(in_string[-1])
        elif inside:
            step[:] = 0
        # the parity of the run of backslashes the block ends with (with the block before's if it is all one)
        other = b[::-1] != 92
        trailing = int(other.argmax()) if b[-1] == 92 and other.any() else (n if b[-1] == 92 else 0)
        odd = trailing % 2 == 1 if trailing < n else odd != (n % 2 == 1)
        running = np.cumsum(step, dtype=np.int64)
        deepest = max(deepest, depth + int(running.max()))
        depth += int(running[-1])
    return deepest


#: the bytes of text scanned at a time by :func:`_json_depth`
_JSON_BLOCK = 1 << 16


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out = dict(pairs)
    if len(out) != len(pairs):
        raise ValueError("duplicate key in a JSON object")
    return out


def parse_meta_json(text: str) -> Any:
    """``text`` read as JSON with the rules of spec 3.1 (no NaN or Infinity, no duplicate key, at most
    ``META_MAX_DEPTH`` deep, every number finite in binary64); a :class:`ValueError` names what breaks them.
    The writer checks its ``META`` with it too, so that it never writes one this reader rejects."""
    # a fixed depth limit (spec 3.1): how deep Python's parser recurses depends on the caller's stack
    if _json_depth(text) > L.META_MAX_DEPTH:
        raise ValueError(f"arrays and objects nest deeper than {L.META_MAX_DEPTH}")
    return json.loads(
        text,
        parse_constant=_reject_constant,
        parse_float=_finite_float,
        parse_int=_finite_int,
        object_pairs_hook=_unique_keys,
    )


def _meta(p: _Parsed, rep: Report) -> None:
    c = _get(p, L.META)
    if c is None:
        return
    try:
        meta = parse_meta_json(p.buf[c.offset : c.offset + c.length].tobytes().decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        rep.add("SWPM_META_BAD_JSON", c.offset, reason=str(exc)[:200])
        p.content_ok = False
        return
    if not isinstance(meta, dict):
        rep.add("SWPM_META_BAD_JSON", c.offset, reason="not an object")
        p.content_ok = False
        return
    if not isinstance(meta.get("params", {}), dict):
        rep.add("SWPM_META_BAD_FIELD", c.offset, field="params", reason="must be an object")
        p.content_ok = False
        return
    if meta.get("encoding", p.encoding) != p.encoding:
        rep.add(
            "SWPM_META_BAD_FIELD", c.offset, field="encoding", reason=f"differs from header ({p.encoding})"
        )
    if p.encoding == "skip-strip":
        # the parameters that change how the lists decode (spec 3.7)
        params = meta.get("params", {})
        restart = params.get("restart_index")
        if params.get("primitive", "strip") not in ("strip", "list"):
            rep.add("SWPM_META_BAD_FIELD", c.offset, field="params.primitive", reason='not "strip" or "list"')
            p.content_ok = False
            return
        if restart is not None and (type(restart) is not int or not 0 <= restart <= 0xFFFFFFFF):
            rep.add("SWPM_META_BAD_FIELD", c.offset, field="params.restart_index", reason="not null or a u32")
            p.content_ok = False
            return
    if p.encoding == "sliding-window":
        # a strip pool is the SW_STRIPS bit and params.primitive "strip" with an integer restart index,
        # both or neither (spec 3.5; a missing primitive is "list", as every file before strips)
        params = meta.get("params", {})
        strips = bool(p.features & L.FEATURE_SW_STRIPS)
        primitive = params.get("primitive", "list")
        restart = params.get("restart_index")
        problem = None
        if primitive not in ("strip", "list"):
            problem = "params.primitive", 'not "strip" or "list"'
        elif (primitive == "strip") != strips:
            problem = (
                "params.primitive",
                f"{primitive!r} but the SW_STRIPS feature bit is {'set' if strips else 'clear'}",
            )
        elif restart is not None and (type(restart) is not int or not 0 <= restart <= 0xFFFFFFFF):
            problem = "params.restart_index", "not null or a u32"
        elif strips and restart is None:
            problem = "params.restart_index", "null in a strip pool"
        if problem is not None:
            rep.add("SWPM_META_BAD_FIELD", c.offset, field=problem[0], reason=problem[1])
            p.content_ok = False
            return

    p.meta = meta
