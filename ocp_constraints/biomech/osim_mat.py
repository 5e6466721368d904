"""MATLAB v5 ``.mat`` files of tables (a struct with ``data`` and ``colheaders``) read without SciPy.

``scipy.io`` costs 0.25-0.3 s of CPU to import (it pulls in ``scipy.sparse`` and SciPy's array-API
layer), as much as the rest of a ``knee`` run's reading, for three small files. The JW exports (IK, GRF,
KCF, ID) are MATLAB 5.0 MAT-files: a 128-byte header, then data elements (an 8-byte tag: type and size,
or a 4-byte "small element"), each variable one ``miMATRIX`` element, zlib-compressed (``miCOMPRESSED``)
by MATLAB 7 and later (MathWorks, "MAT-File Format", R2024a, chapter 1: "Level 5 MAT-File Format").
:func:`loadmat` reads the subset those files use: structs, cells, character arrays and real numeric
arrays, little-endian. The numbers are the file's bytes reinterpreted (``numpy.frombuffer`` of the stored
type) and, for a numeric array, converted to ``float64``, which is exact for every stored type MATLAB
writes a ``double`` as (``miDOUBLE``, and the integer types it narrows integral values to); the tests check the
result equal, bit for bit, to ``scipy.io.loadmat``'s on the JW files.

Anything else (MATLAB v4 or v7.3 files, big-endian, complex, sparse, logical, objects, multi-row character
arrays, a damaged or truncated file) is left to ``scipy.io.loadmat`` (``squeeze_me=True,
struct_as_record=False``), whose results and error messages the readers had before: this module only
saves its import where the file is one it can read exactly.
"""
from __future__ import annotations

import struct
import zlib
from types import SimpleNamespace

import numpy as np

_NUMERIC = {1: "<i1", 2: "<u1", 3: "<i2", 4: "<u2", 5: "<i4", 6: "<u4", 7: "<f4", 9: "<f8", 12: "<i8", 13: "<u8"}
_MATRIX, _COMPRESSED = 14, 15
_CELL, _STRUCT, _CHAR = 1, 2, 4
_NUMERIC_CLASSES = set(range(6, 16))        # mxDOUBLE ... mxUINT64
_COMPLEX, _LOGICAL = 0x0800, 0x0200


class _Unsupported(Exception):
    """A construct this reader leaves to SciPy."""


def loadmat(path) -> dict:
    """The variables of a MATLAB file as ``scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)``
    gives those a table reader uses: a 1 x 1 struct as an object with ``_fieldnames`` and its fields, numeric
    arrays squeezed, character rows as ``str``, cells as object arrays of their (squeezed) elements."""
    try:
        with open(path, "rb") as f:
            raw = f.read()
        return _variables(raw)
    except Exception:  # noqa: BLE001 - not a file this reader handles (or damaged): SciPy decides and explains
        import scipy.io

        return scipy.io.loadmat(str(path), squeeze_me=True, struct_as_record=False)


def _variables(raw: bytes) -> dict:
    if len(raw) < 128 or not raw.startswith(b"MATLAB 5.0 MAT-file") or raw[126:128] != b"IM" \
            or raw[124:126] != b"\x00\x01":
        raise _Unsupported("not a little-endian MATLAB 5.0 file")
    out, pos = {}, 128
    while pos < len(raw):
        kind, size, body, pos = _element(raw, pos, top=True)
        if kind == _COMPRESSED:
            kind, size, body, _ = _element(zlib.decompress(body), 0)
        if kind != _MATRIX:
            raise _Unsupported(f"top-level element of type {kind}")
        name, value = _matrix(body)
        if name in out:
            raise _Unsupported(f"variable {name!r} twice")
        out[name] = value
    return out


def _element(buf: bytes, pos: int, top: bool = False) -> tuple[int, int, bytes, int]:
    """``(type, size, data, next position)`` of the data element at ``pos``."""
    kind, size = struct.unpack_from("<II", buf, pos)
    if kind >> 16:                               # small data element: size in the upper 16 bits, data in 4 bytes
        kind, size = kind & 0xFFFF, kind >> 16
        return kind, size, buf[pos + 4:pos + 4 + size], pos + 8
    end = pos + 8 + size
    if end > len(buf):
        raise _Unsupported("truncated element")
    # elements are padded to 8 bytes, but a top-level compressed one ends where its size says
    nxt = end if (top and kind == _COMPRESSED) else pos + 8 + (size + 7) // 8 * 8
    return kind, size, buf[pos + 8:end], nxt


def _matrix(body: bytes) -> tuple[str, object]:
    """Name and value of an ``miMATRIX`` element's contents."""
    if not body:                                 # an empty matrix (e.g. an empty cell element), as SciPy's
        return "", np.array([])
    kind, _, flags, pos = _element(body, 0)
    flags = struct.unpack_from("<I", flags)[0]
    cls = flags & 0xFF
    if kind != 6 or flags & (_COMPLEX | _LOGICAL):
        raise _Unsupported("complex, logical or malformed array flags")
    kind, _, dims, pos = _element(body, pos)
    dims = tuple(int(d) for d in np.frombuffer(dims, "<i4"))
    kind, _, name, pos = _element(body, pos)
    name = name.decode("ascii")
    count = int(np.prod(dims))
    if cls in _NUMERIC_CLASSES:
        kind, _, data, pos = _element(body, pos)
        if kind not in _NUMERIC:
            raise _Unsupported(f"numeric data of type {kind}")
        arr = np.frombuffer(data, _NUMERIC[kind])
        if arr.size != count:
            raise _Unsupported("numeric data and dimensions disagree")
        return name, _squeeze(arr.reshape(dims[::-1]).T)
    if cls == _CHAR:
        kind, _, data, pos = _element(body, pos)
        text = {2: lambda b: b.decode("latin-1"), 4: lambda b: b.decode("utf-16-le"),
                16: lambda b: b.decode("utf-8"), 17: lambda b: b.decode("utf-16-le")}.get(kind)
        if text is None or len(dims) != 2 or dims[0] != 1 or dims[1] == 0:
            raise _Unsupported("a character array other than one non-empty row")
        value = text(data)
        if len(value) != dims[1]:
            raise _Unsupported("characters outside the basic plane")
        return name, value
    if cls == _CELL:
        items = []
        for _ in range(count):
            kind, _, sub, pos = _element(body, pos)
            if kind != _MATRIX:
                raise _Unsupported("a cell element that is not a matrix")
            items.append(_matrix(sub)[1])
        cell = np.empty(count, dtype=object)
        cell[:] = items
        return name, _squeeze(cell.reshape(dims[::-1]).T)
    if cls == _STRUCT and count == 1:
        kind, _, length, pos = _element(body, pos)
        length = struct.unpack_from("<i", length)[0]
        kind, _, names, pos = _element(body, pos)
        fields = [names[i:i + length].split(b"\0", 1)[0].decode("ascii") for i in range(0, len(names), length)]
        value = SimpleNamespace(_fieldnames=fields)
        for field in fields:
            kind, _, sub, pos = _element(body, pos)
            if kind != _MATRIX:
                raise _Unsupported("a struct field that is not a matrix")
            setattr(value, field, _matrix(sub)[1])
        return name, value
    raise _Unsupported(f"MATLAB class {cls}")


def _squeeze(arr: np.ndarray):
    """As SciPy's ``squeeze_me``: unit dimensions dropped; a single element as itself."""
    if not arr.size:
        return arr
    out = np.squeeze(arr)
    return out.item() if not out.shape and out.dtype.isbuiltin else out
