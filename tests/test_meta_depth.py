"""The META nesting pre-scan (spec/format.md 3.1: at most 128 deep, checked before parsing) against the scan
it replaced: the vectorised :func:`_json_depth` gives the same depth on random and adversarial text (escaped
quotes, runs of backslashes inside and outside strings, brackets in strings, unpaired surrogates,
unterminated strings, nests just under and over the limit), and :func:`parse_meta_json` the same outcome.
"""

from __future__ import annotations

import json
import random
import re
import time
import tracemalloc

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from swpm_usd.format import layout as L
from swpm_usd.format import meta as M
from swpm_usd.format.meta import _json_depth
from swpm_usd.format.reader import parse_meta_json

#: the scan before (a string literal skipped whole, or a bracket), kept here as the reference
_REFERENCE = re.compile(r'"(?:[^"\\]++|\\.)*+"?|[\[\]{}]', re.DOTALL)


def _reference_depth(text: str) -> int:
    depth = deepest = 0
    for m in _REFERENCE.finditer(text):
        tok = m.group()
        if tok in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif tok in "]}":
            depth -= 1
    return deepest


def _outcome(text: str) -> tuple[str, object]:
    try:
        return "ok", parse_meta_json(text)
    except ValueError as e:
        return "error", str(e)


def _reference_outcome(text: str) -> tuple[str, object]:
    """What ``parse_meta_json`` did with the scan before: its depth check, then the same parse."""
    if _reference_depth(text) > L.META_MAX_DEPTH:
        return "error", f"arrays and objects nest deeper than {L.META_MAX_DEPTH}"
    try:
        return "ok", json.loads(
            text,
            parse_constant=M._reject_constant,
            parse_float=M._finite_float,
            parse_int=M._finite_int,
            object_pairs_hook=M._unique_keys,
        )
    except ValueError as e:
        return "error", str(e)


#: the characters that matter to the scan, and some that must not (multi-byte, surrogates, NUL, newline)
ALPHABET = ['"', "\\", "[", "]", "{", "}", "a", ",", ":", "1", " ", "\n", "\x00"]
ALPHABET += ["é", "€", "😀", "\ud800", "\udfff"]


def _random_text(rng: random.Random) -> str:
    kind = rng.randrange(4)
    if kind == 0:  # uniform over the alphabet
        return "".join(rng.choice(ALPHABET) for _ in range(rng.randrange(60)))
    if kind == 1:  # mostly backslashes and quotes: runs of every parity, inside and outside strings
        return "".join(rng.choice('\\\\\\""[]{a') for _ in range(rng.randrange(80)))
    if kind == 2:  # valid JSON nests around strings holding brackets and escapes
        value: object = rng.choice(['[{\\"', '"]}', "\\", "\ud800", "x"])
        for _ in range(rng.randrange(1, 140)):
            value = [value] if rng.random() < 0.5 else {rng.choice(['k"[', "k\\", "k"]): value}
        text = json.dumps(value, ensure_ascii=rng.random() < 0.5)
        if rng.random() < 0.3:  # then damaged
            i = rng.randrange(len(text) + 1)
            text = text[:i] + rng.choice(ALPHABET) + text[i + rng.randrange(3) :]
        return text
    # brackets nested to around the limit, with a string cut open or closed somewhere
    depth = rng.randrange(L.META_MAX_DEPTH - 3, L.META_MAX_DEPTH + 4)
    middle = rng.choice(['"', '"\\"', '"\\\\"', '\\"', '"[[[', "", '"a\\'])
    return "[" * depth + middle + "]" * rng.randrange(depth + 2)


def test_same_depth_as_the_previous_scan_on_random_text() -> None:
    rng = random.Random(109)
    for _ in range(8000):
        text = _random_text(rng)
        assert _json_depth(text) == _reference_depth(text), repr(text)
        assert _outcome(text) == _reference_outcome(text), repr(text)


@settings(
    max_examples=1500, deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck)
)
@given(text=st.text(alphabet=st.sampled_from(ALPHABET), max_size=120))
def test_same_depth_and_outcome_as_the_previous_scan(text: str) -> None:
    assert _json_depth(text) == _reference_depth(text)
    assert _outcome(text) == _reference_outcome(text)


@pytest.mark.parametrize(
    "text, depth",
    [
        ("", 0),
        ("]]]", 0),
        ("[]]][[", 1),
        ('"[', 0),  # an unterminated string runs to the end
        ('\\"[', 0),  # a backslash outside a string escapes nothing: the quote opens a string
        ('"\\"[', 0),  # an escaped quote inside a string ends nothing
        ('"\\\\"[', 1),  # an escaped backslash: the quote ends the string
        ('"\\\\\\"[', 0),
        ('"a\\', 0),  # a backslash at the end
        ('["\ud800[",[', 2),
        ("[" * 128 + "]" * 128, 128),
        ("[" * 129, 129),
        ('{"a":"' + "[" * 300 + '"}', 1),
    ],
)
def test_edge_cases(text: str, depth: int) -> None:
    assert _json_depth(text) == depth == _reference_depth(text)


@pytest.mark.parametrize("depth", [127, 128, 129])
def test_the_limit_is_checked_as_before(depth: int) -> None:
    text = "[" * (depth - 1) + '{"a":"]]]\\""}' + "]" * (depth - 1)
    assert _json_depth(text) == depth
    if depth <= L.META_MAX_DEPTH:
        assert isinstance(parse_meta_json(text), list)
    else:
        with pytest.raises(ValueError, match="nest deeper than 128"):
            parse_meta_json(text)


def test_fast_on_a_deep_nest_and_on_escaped_quotes() -> None:
    """A 2.9 MB bracket nest took the scan about 1 s in Python; 40 KB of escaped quotes in an unterminated
    string (the quadratic case of a scan that restarts at each quote) stays fast too."""
    nest = "[" * 1_450_000 + "]" * 1_450_000
    quotes = '{"params":{},"a":"' + '\\"' * 20000
    assert _json_depth(nest) == 1_450_000
    with pytest.raises(ValueError, match="nest deeper"):
        parse_meta_json(nest)
    assert _json_depth(quotes) == 2  # (the object and params; the rest is one string)
    best = []
    for _ in range(3):  # the best of three: the machine is shared
        start = time.perf_counter()
        _json_depth(nest)
        _json_depth(quotes)
        best.append(time.perf_counter() - start)
    # a guard against the quadratic scan (10 s on the quotes, tests/test_format_adversarial.py), not a speed
    # target: 0.01 s measured for both, the scan before 0.8-1.2 s on the nest (benchmarks hold speed targets)
    assert min(best) < 5.0


def test_memory_is_a_few_bytes_per_byte_of_text() -> None:
    """The scan holds a few one-byte arrays of the text and sums its depth a block at a time: 11.6 MB traced
    for the 2.9 MB nest (a first vectorised version, with 8-byte positions and sums over the whole text,
    held 113 MB)."""
    nest = "[" * 1_450_000 + "]" * 1_450_000
    tracemalloc.start()
    try:
        assert _json_depth(nest) == 1_450_000
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5 * len(nest) + (2 << 20)


@pytest.mark.parametrize("block", [1, 2, 3, 4, 7, 64])
def test_same_depth_when_the_scan_is_cut_in_blocks(block: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The text scanned a few bytes at a time: a string, or a run of backslashes, open across the cut."""
    monkeypatch.setattr(M, "_JSON_BLOCK", block)
    rng = random.Random(114 + block)
    # a block of a few bytes cuts every text at most of its places, so fewer texts reach as many states
    # (3,000 at block 1 took 55 s of a loaded suite)
    texts = [_random_text(rng) for _ in range(3000 if block >= 64 else 600)]
    texts += [
        '\\"[',
        '"\\"[',
        '"\\\\"[',
        '"\\\\\\"[',
        '\\\\\\\\\\"[',
        '"\\\\\\\\\\"[',
        '"' * 9 + "[",
        'é€😀["\\',
    ]
    for text in texts:
        assert _json_depth(text) == _reference_depth(text), repr(text)


@pytest.mark.parametrize(
    "text",
    [
        '"' * 2_900_000,  # (each quote an 8-byte position, and its state)
        '\\"' * 1_450_000,  # (with a backslash run before each)
        '\\""' * 966_666,
        '"[' * 1_450_000,
    ],
    ids=["quotes", "escaped-quotes", "escaped-and-plain-quotes", "strings-and-brackets"],
)
def test_memory_is_a_few_bytes_per_byte_of_any_text(text: str) -> None:
    """Quotes and backslashes are 8-byte positions, each with a state: a META of quotes scanned whole held
    44-48 bytes per byte of text (128-138 MB traced for 2.9 MB; a META has no size limit but the file's), a
    block at a time the same few bytes per byte as a nest."""
    _json_depth(text[:100])
    tracemalloc.start()
    try:
        depth = _json_depth(text)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert depth == _reference_depth(text)
    assert peak < 5 * len(text) + (8 << 20)
