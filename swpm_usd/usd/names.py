"""USD identifiers made from file names: one rule for an asset layer's root prim and the scene's prims.

usd-core 24.03 and later read UTF-8 identifiers (XID_Start then XID_Continue: ``café``, ``日本``), where
``Tf.MakeValidIdentifier`` is ASCII's and mangles each non-ASCII character (``café`` -> ``caf___``).
"""

from __future__ import annotations


def valid_identifier(stem: str) -> str:
    """``stem`` as a USD identifier: an ASCII stem as ``Tf.MakeValidIdentifier`` makes it (each character
    but ``[A-Za-z0-9_]`` and a leading digit ``_``, as always); a non-ASCII one as the installed usd-core
    reads identifiers (``Sdf.Path.IsValidIdentifier``), each character it refuses ``_``: an older usd-core,
    which takes no UTF-8 identifier, gets ASCII's ``_`` for each non-ASCII character."""
    from pxr import Sdf, Tf  # (here: a pipeline run that writes no USD never loads pxr)

    if stem.isascii() or not stem:
        return Tf.MakeValidIdentifier(stem)
    if Sdf.Path.IsValidIdentifier(stem):
        return stem
    first = stem[0] if Sdf.Path.IsValidIdentifier(stem[0]) else "_"
    return first + "".join(ch if Sdf.Path.IsValidIdentifier(f"_{ch}") else "_" for ch in stem[1:])
