"""How two hdf5 files differ in content, bit for bit: the tests' check that demos recorded with one
worker and with several (locally or on Ray) are the same dataset."""

from __future__ import annotations

from typing import Sequence

import numpy as np

#: ``data`` attributes that tell when a file was written, not what it holds (ignored by `dataset_differences`).
WRITE_TIME_ATTRS = ("date",)


def dataset_differences(path_a, path_b, ignore_attrs: Sequence[str] = WRITE_TIME_ATTRS) -> list[str]:
    """How two hdf5 files differ in content: every group, dataset and attribute, bit for bit.

    Datasets must have the same dtype, shape and bytes; attributes the same type and value
    (arrays: dtype, shape and bytes).  Attributes named in ``ignore_attrs`` (on any object; by
    default the write date) are skipped.  Returns one line per difference, ``[]`` when the
    files hold the same data (e.g. demos recorded with one worker and with several).
    """
    import h5py

    def contents(path) -> dict:
        found = {}

        def add(name: str, obj) -> None:
            if isinstance(obj, h5py.Dataset):
                value = obj[()]
                found[name] = ("dataset", obj.dtype.str, obj.shape, np.asarray(value).tobytes())
            else:
                found[name] = ("group",)
            for key, value in obj.attrs.items():
                if key not in ignore_attrs:
                    found[f"{name}@{key}"] = _comparable_attr(value)

        with h5py.File(path, "r") as f:
            add("/", f)
            f.visititems(add)
        return found

    a, b = contents(path_a), contents(path_b)
    lines = [f"only in {path_a}: {name}" for name in sorted(set(a) - set(b))]
    lines += [f"only in {path_b}: {name}" for name in sorted(set(b) - set(a))]
    lines += [f"{name} differs" for name in sorted(set(a) & set(b)) if a[name] != b[name]]
    return lines


def _comparable_attr(value):
    """An hdf5 attribute as a value ``==`` compares exactly (arrays by dtype, shape and bytes)."""
    if isinstance(value, np.ndarray):
        return ("array", value.dtype.str, value.shape, value.tobytes())
    if isinstance(value, np.generic):
        return ("scalar", value.dtype.str, value.tobytes())
    return (type(value).__name__, value)
