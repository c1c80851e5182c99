"""What to say of a parameter name an encoding does not take (``-p``, a config's ``params``,
:func:`swpm_usd.build`): the encodings that take it, else the name meant.

Apart from :mod:`swpm_usd.encodings` on purpose: the kernels import that module, so a change to it is a change
to the kernels' fingerprint (:mod:`swpm_usd.numba_cache`), which compiles every kernel again once.
"""

from __future__ import annotations

import difflib
from typing import Any

from .encodings import ENCODING_PARAMS


def did_you_mean(word: Any, known: list[str]) -> str:
    """``did you mean 'vanilla'?`` for a misspelt name, the closest of ``known`` (by
    :func:`difflib.get_close_matches`), or "" when none is close (a case or separator slip counts:
    ``optimise_connectivity``, ``Sliding_Window``) or ``word`` is no string (a key YAML read as another
    type, ``on:``: its own message says so)."""
    if not isinstance(word, str):
        return ""
    folded = {k.lower().replace("_", "-"): k for k in known}
    close = difflib.get_close_matches(word.lower().replace("_", "-"), list(folded), n=1, cutoff=0.75)
    return f"did you mean {folded[close[0]]!r}?" if close else ""


def taken_elsewhere(encoding: str, name: str) -> str:
    """``"sliding-window takes it"`` for ``name``, a parameter ``encoding`` does not take but others do (``-p
    mu=0.2`` under the default ``vanilla``, a first user's slip), else ""."""
    others = [e for e, params in ENCODING_PARAMS.items() if e != encoding and name in params]
    return f"{' and '.join(others)} take{'s' * (len(others) == 1)} it" if others else ""


def unknown_param_hint(encoding: str, name: str) -> str:
    """What to say of ``name``, a parameter ``encoding`` does not take: :func:`taken_elsewhere`, else the
    closest of ``encoding``'s own names (``did you mean 'mu'?``), else ""."""
    elsewhere = taken_elsewhere(encoding, name)
    if elsewhere:
        return elsewhere
    return did_you_mean(name, list(ENCODING_PARAMS.get(encoding, {})))
