"""SWPM binary format v1 (spec/format.md): :func:`save`, :func:`load`, :func:`validate`, error catalogue."""

from __future__ import annotations

from .errors import CATALOGUE, Problem, Report, SwpmEncodeError, SwpmFormatError
from .reader import load, load_bytes, validate, validate_bytes
from .writer import encode_bytes, save

__all__ = [
    "CATALOGUE",
    "Problem",
    "Report",
    "SwpmEncodeError",
    "SwpmFormatError",
    "encode_bytes",
    "load",
    "load_bytes",
    "save",
    "validate",
    "validate_bytes",
]
