"""SWPM binary format v1 (spec/format.md): :func:`save`, :func:`load`, :func:`validate`, error catalogue, and
:func:`open_prefix` (a file's first bytes, spec 4.1: its coarse LODs before the whole file has arrived) and
:func:`open_ranges` / :func:`read_lod` (byte ranges, spec 4.2: a band's LODs from ``SMAP``'s ranges)."""

from __future__ import annotations

from .._lazy import lazy_attributes

# the reader and the writer load numba and the encoders: imported on first use (:mod:`swpm_usd._lazy`), so
# that the command line's modules (``swpm_usd.format.cli``) import without them. The catalogue too (light):
# imported here, ``python -m swpm_usd.format.errors`` would find it loaded and runpy would warn
__getattr__, __dir__ = lazy_attributes(
    __name__,
    {
        **dict.fromkeys(("CATALOGUE", "Problem", "Report", "SwpmEncodeError", "SwpmFormatError"), "errors"),
        "load": "reader",
        "load_bytes": "reader",
        "validate": "reader",
        "validate_bytes": "reader",
        "encode_bytes": "writer",
        "save": "writer",
        "FilePrefix": "prefix",
        "open_prefix": "prefix",
        "validate_prefix": "prefix",
        "FileRanges": "ranges",
        "open_ranges": "ranges",
        "ranges_for_lod": "ranges",
        "read_lod": "ranges",
        "validate_ranges": "ranges",
    },
)

__all__ = [
    "CATALOGUE",
    "FilePrefix",
    "FileRanges",
    "Problem",
    "Report",
    "SwpmEncodeError",
    "SwpmFormatError",
    "encode_bytes",
    "load",
    "load_bytes",
    "open_prefix",
    "open_ranges",
    "ranges_for_lod",
    "read_lod",
    "save",
    "validate",
    "validate_bytes",
    "validate_prefix",
    "validate_ranges",
]
