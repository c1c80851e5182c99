"""numpy <-> Vt array conversions for the swpm: attributes (vectorised, dtype-checked, no Python loops)."""

from __future__ import annotations

import numpy as np
from pxr import Sdf, Vt

from ..errors import SwpmError
from .schema import PROPERTY_TYPES

# numpy dtype -> (Sdf value type name, Vt array class, storage dtype)
_BY_DTYPE: dict[str, tuple[Sdf.ValueTypeName, type, np.dtype]] = {
    "bool": (Sdf.ValueTypeNames.BoolArray, Vt.BoolArray, np.dtype(bool)),
    "uint8": (Sdf.ValueTypeNames.UCharArray, Vt.UCharArray, np.dtype(np.uint8)),
    "uint16": (Sdf.ValueTypeNames.UIntArray, Vt.UIntArray, np.dtype(np.uint32)),
    "uint32": (Sdf.ValueTypeNames.UIntArray, Vt.UIntArray, np.dtype(np.uint32)),
    "uint64": (Sdf.ValueTypeNames.UInt64Array, Vt.UInt64Array, np.dtype(np.uint64)),
    "int8": (Sdf.ValueTypeNames.IntArray, Vt.IntArray, np.dtype(np.int32)),
    "int16": (Sdf.ValueTypeNames.IntArray, Vt.IntArray, np.dtype(np.int32)),
    "int32": (Sdf.ValueTypeNames.IntArray, Vt.IntArray, np.dtype(np.int32)),
    "int64": (Sdf.ValueTypeNames.Int64Array, Vt.Int64Array, np.dtype(np.int64)),
    "float16": (Sdf.ValueTypeNames.FloatArray, Vt.FloatArray, np.dtype(np.float32)),
    "float32": (Sdf.ValueTypeNames.FloatArray, Vt.FloatArray, np.dtype(np.float32)),
    "float64": (Sdf.ValueTypeNames.DoubleArray, Vt.DoubleArray, np.dtype(np.float64)),
}
_BY_SDF = {
    "uint[]": (Sdf.ValueTypeNames.UIntArray, Vt.UIntArray, np.dtype(np.uint32)),
    "int[]": (Sdf.ValueTypeNames.IntArray, Vt.IntArray, np.dtype(np.int32)),
    "float[]": (Sdf.ValueTypeNames.FloatArray, Vt.FloatArray, np.dtype(np.float32)),
}


#: the dtype names ``swpm:bufferDtypes`` may hold (integer buffers) and ``swpm:attributeDtypes`` (numbers
#: and bool: a bool attribute is stored as a float primvar of 0 / 1): those the writer stores. A reader casts
#: to them, so any other name (``V1000000000``: 1 GB per element) is refused.
BUFFER_DTYPES = tuple(n for n in _BY_DTYPE if np.dtype(n).kind in "ui")
ATTRIBUTE_DTYPES = tuple(n for n in _BY_DTYPE if np.dtype(n).kind in "buif")


def dtype_problem(attribute: str, tokens: object, allowed: tuple[str, ...]) -> str | None:
    """Why the dtype names ``tokens`` of ``attribute`` are not all in ``allowed`` (the first that is not), or
    None when they are."""
    for i, token in enumerate(tokens or []):
        if str(token) not in allowed:
            return f"{attribute}[{i}] = {str(token)!r} is not one of {', '.join(allowed)}"
    return None


class ArrayTypeError(SwpmError):
    """A buffer cannot be stored losslessly in its attribute type."""

    code = "OUTPUT_UNSUPPORTED"


def storage_for(name: str, dtype: np.dtype) -> tuple[Sdf.ValueTypeName, type, np.dtype]:
    """Sdf type, Vt class and storage dtype of attribute ``name`` holding ``dtype`` data."""
    known = PROPERTY_TYPES.get(name)
    if known in _BY_SDF:
        return _BY_SDF[known]
    try:
        return _BY_DTYPE[np.dtype(dtype).name]
    except KeyError:
        raise ArrayTypeError(f"{name}: no USD array type for dtype {np.dtype(dtype)}") from None


def to_vt(name: str, a: np.ndarray) -> tuple[Sdf.ValueTypeName, object]:
    """(Sdf type, Vt array) storing the flattened ``a`` in attribute ``name``; lossless or ArrayTypeError."""
    a = np.asarray(a)
    sdf, vt, store = storage_for(name, a.dtype)
    flat = np.ascontiguousarray(a.reshape(-1))
    if flat.dtype != store:
        if flat.size and np.issubdtype(flat.dtype, np.integer) and np.issubdtype(store, np.integer):
            info = np.iinfo(store)
            lo, hi = int(flat.min()), int(flat.max())
            if lo < info.min or hi > info.max:
                raise ArrayTypeError(f"{name}: values [{lo}, {hi}] do not fit {store} ({sdf})")
        elif flat.size and not np.can_cast(flat.dtype, store, casting="same_kind"):
            raise ArrayTypeError(f"{name}: {flat.dtype} cannot be stored as {sdf}")
        flat = flat.astype(store)
    return sdf, vt.FromNumpy(flat)


def from_vt(value: object, dtype: np.dtype | str, columns: int = 0) -> np.ndarray:
    """A Vt array read from an attribute -> numpy of ``dtype`` (a zero-copy view when the dtype matches)."""
    a = np.asarray(value) if value is not None else np.zeros(0)
    a = a.astype(np.dtype(dtype), copy=False)
    return a.reshape(-1, columns) if columns else a.reshape(-1)
