"""The version a pipeline digest holds: the release that last changed what an asset's build writes.

The digest held the tool's version, so every release rebuilt every asset, though most change one encoding
(0.9.1 changed only the sliding window's pool order). :data:`BUILD_VERSIONS` names, for each encoding and
for everything else a build uses (``base``: loading, the collapse sequence, the ``.swpm`` and USD writers, the
record), the release that last changed its outputs; an asset's digest holds ``base`` and its encoding's
(for ``auto``, which builds them all to choose, ``auto``'s and every encoding's). A release that changes
one encoding's outputs and nothing else bumps that entry; any other change of an output bumps ``base``; a
release that changes no output bumps nothing, and rebuilds nothing.
"""

from __future__ import annotations

from typing import Any

from ..encodings import ENCODING_PARAMS

#: part -> the release that last changed its outputs (0.9.2: the digest's first release of build versions,
#: which rebuilt everything once; base 0.9.4: loaders that misread some inputs silently read them right, an
#: OBJ with indented or tab-led rows, an OFF with comments among its rows, a byte-order mark or lone CRs, a
#: PLY with a byte-order mark and mixed polygons). Keep one entry per encoding in ENCODING_PARAMS (a test
#: checks).
BUILD_VERSIONS: dict[str, str] = {
    "base": "0.9.4",
    "auto": "0.9.2",  # ``encoding: auto``'s choice among the encodings it builds
    "vanilla": "0.9.2",
    "skip-strip": "0.9.2",
    "mixed": "0.9.2",
    "sliding-window": "0.9.6",  # (small levels keep the greedy patch order where the search ends worse)
}


def build_version(treatment: dict[str, Any]) -> str:
    """What ``treatment``'s digest holds for the version: ``base`` and its encoding's entries of
    :data:`BUILD_VERSIONS` (``"base 0.9.2, sliding-window 0.9.3"``), ``auto``'s and every encoding's for
    ``auto``."""
    encoding = treatment.get("encoding")
    parts = ["auto", *sorted(ENCODING_PARAMS)] if encoding == "auto" else [encoding]
    # (an encoding no release knows, a record's from a newer tool: a digest no build of this one reproduces)
    return ", ".join(f"{p} {BUILD_VERSIONS.get(p, 'unknown')}" for p in ["base", *parts])
