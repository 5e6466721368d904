"""The SciPy-free MATLAB v5 reader (:mod:`ocp_constraints.biomech.osim_mat`) gives scipy.io.loadmat's result.

scipy.io is the independent reference: its reader (and, for the generated files, its writer ``savemat``) is
another implementation of the MAT-file format. Equal means same variables in the same order, same fields,
same types, shapes and dtypes, and the same bytes for every numeric array.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

scipy_io = pytest.importorskip("scipy.io")

from ocp_constraints.biomech.osim_mat import _Unsupported, _variables, loadmat  # noqa: E402

J = Path(__file__).resolve().parents[2] / "shared" / "data" / "grand-challenge-knee-jw" / "reducepoly_subject_GC"
JW_FILES = [J / k / f"{k}_ngait_og5.mat" for k in ("IK", "GRF", "KCF", "ID")]


def _same(mine, ref, where: str) -> None:
    if hasattr(ref, "_fieldnames"):
        assert list(mine._fieldnames) == list(ref._fieldnames), where
        for f in ref._fieldnames:
            _same(getattr(mine, f), getattr(ref, f), f"{where}.{f}")
    elif isinstance(ref, np.ndarray):
        assert isinstance(mine, np.ndarray), where
        assert (mine.shape, mine.dtype) == (ref.shape, ref.dtype), where
        if ref.dtype == object:
            for x, y in zip(mine.ravel(), ref.ravel()):
                _same(x, y, f"{where}[]")
        else:
            assert mine.tobytes() == ref.tobytes(), where
    else:
        assert type(mine) is type(ref) and mine == ref, where


def _scipy(path) -> dict:
    return {k: v for k, v in scipy_io.loadmat(str(path), squeeze_me=True, struct_as_record=False).items()
            if not k.startswith("__")}


@pytest.mark.parametrize("path", JW_FILES, ids=lambda p: p.name)
def test_jw_exports_read_bit_for_bit_as_scipy(path):
    if not path.exists():
        pytest.skip(f"{path} not here")
    mine = _variables(path.read_bytes())          # the fast path itself: no fallback hides a difference
    ref = _scipy(path)
    assert list(mine) == list(ref)
    for k in ref:
        _same(mine[k], ref[k], k)


@pytest.mark.parametrize("compress", [False, True], ids=["plain", "compressed"])
def test_tables_written_by_scipy_read_as_scipy(tmp_path, compress):
    rng = np.random.default_rng(7)
    path = tmp_path / "table.mat"
    heads = np.empty((1, 4), dtype=object)
    heads[0, :] = ["time", "knee_angle_r", "hip_flexion_r", "pelvis_tx"]
    text = np.empty((1, 2), dtype=object)
    text[0, :] = ["inDegrees=yes", "version=1"]
    scipy_io.savemat(str(path), {"other": np.arange(6.0).reshape(2, 3), "Qsall": {
        "data": rng.normal(size=(50, 4)) * 10.0 ** rng.integers(-8, 8, size=(50, 4)), "colheaders": heads,
        "textdata": text, "count": np.uint8(3), "one": np.array([[2.5]])}}, do_compression=compress)
    mine, ref = _variables(path.read_bytes()), _scipy(path)
    assert list(mine) == list(ref) == ["other", "Qsall"]
    for k in ref:
        _same(mine[k], ref[k], k)


def test_files_it_does_not_read_go_to_scipy(tmp_path):
    """Complex data: the fast reader refuses, :func:`loadmat` returns SciPy's result."""
    path = tmp_path / "complex.mat"
    scipy_io.savemat(str(path), {"z": np.array([[1 + 2j, 3 - 1j]])})
    with pytest.raises(_Unsupported):
        _variables(path.read_bytes())
    _same(loadmat(path)["z"], _scipy(path)["z"], "z")


def test_a_damaged_file_fails_as_in_scipy(tmp_path):
    path = tmp_path / "bad.mat"
    path.write_bytes(b"MATLAB 5.0 MAT-file" + b"\0" * 200)
    with pytest.raises(Exception) as ours:
        loadmat(path)
    with pytest.raises(Exception) as theirs:
        scipy_io.loadmat(str(path), squeeze_me=True, struct_as_record=False)
    assert type(ours.value) is type(theirs.value) and str(ours.value) == str(theirs.value)
