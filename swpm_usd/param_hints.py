"""What to say of a parameter name an encoding does not take (``-p``, a config's ``params``,
:func:`swpm_usd.build`): the encodings that take it, else the name meant.

Apart from :mod:`swpm_usd.encodings` on purpose: the kernels import that module, so a change to it is a change
to the kernels' fingerprint (:mod:`swpm_usd.numba_cache`), which compiles every kernel again once.
"""

from __future__ import annotations

import difflib
from typing import Any

from .encodings import ENCODING_PARAMS


def closest_name(word: Any, known: list[str]) -> str | None:
    """The name of ``known`` closest to ``word`` (by :func:`difflib.get_close_matches`), or None when none
    is close (a case or separator slip counts: ``optimise_connectivity``, ``Sliding_Window``) or ``word`` is
    no string (a key YAML read as another type, ``on:``: its own message says so)."""
    if not isinstance(word, str):
        return None
    folded = {k.lower().replace("_", "-"): k for k in known}
    close = difflib.get_close_matches(word.lower().replace("_", "-"), list(folded), n=1, cutoff=0.75)
    return folded[close[0]] if close else None


def did_you_mean(word: Any, known: list[str]) -> str:
    """``did you mean 'vanilla'?`` for a misspelt name (:func:`closest_name`), or ""."""
    meant = closest_name(word, known)
    return f"did you mean {meant!r}?" if meant else ""


def taken_elsewhere(encoding: str, name: str) -> str:
    """``"sliding-window takes it"`` for ``name``, a parameter ``encoding`` does not take but others do (``-p
    mu=0.2`` under the default ``vanilla``, a first user's slip), else ""."""
    others = [e for e, params in ENCODING_PARAMS.items() if e != encoding and name in params]
    return f"{' and '.join(others)} take{'s' * (len(others) == 1)} it" if others else ""


def unknown_param_hint(encoding: str, name: str) -> str:
    """What to say of ``name``, a parameter ``encoding`` does not take: :func:`taken_elsewhere`, else the
    closest of ``encoding``'s own names (``did you mean 'mu'?``), else the closest of the other encodings'
    names with who takes it (``did you mean 'mu'? sliding-window takes it``), else ""."""
    return (
        taken_elsewhere(encoding, name)
        or did_you_mean(name, list(ENCODING_PARAMS.get(encoding, {})))
        or meant_elsewhere(encoding, name)
    )


def meant_elsewhere(encoding: str, name: Any) -> str:
    """``did you mean 'mu'? sliding-window takes it`` for ``name``, a slip on a parameter of an encoding other
    than ``encoding`` (``-p MU=0.2`` under vanilla; none of ``encoding``'s own names close), else "". Shared
    by :func:`unknown_param_hint` (``-p``, :func:`swpm_usd.build`) and a config's unknown ``params`` key, so
    both say the same of the same slip."""
    own = set(ENCODING_PARAMS.get(encoding, {}))
    if closest_name(name, list(own)):
        return ""  # (the encoding's own name is the one meant: did_you_mean says so)
    others = sorted({p for e, ps in ENCODING_PARAMS.items() if e != encoding for p in ps} - own)
    meant = closest_name(name, others)
    return f"did you mean {meant!r}? {taken_elsewhere(encoding, meant)}" if meant else ""
