#!/usr/bin/env python3
"""compare_h5.py A.h5 B.h5 [ATTRIBUTE...]: exit 0 when every group, dataset and attribute of the two HDF5 files
is equal bit for bit (same dtype, shape and bytes), except the attributes named (tests/mpi/mpi_compare.sh)."""
import sys

import h5py
import numpy as np

a, b, skip = h5py.File(sys.argv[1], "r"), h5py.File(sys.argv[2], "r"), set(sys.argv[3:])
bad = []


def same(x, y):
    x, y = np.asarray(x), np.asarray(y)
    return x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()


def compare(name):
    ga, gb = (a[name], b[name]) if name else (a, b)
    if set(ga.attrs) != set(gb.attrs):
        bad.append(f"{name}: attribute names")
    for k in ga.attrs:
        if k not in skip and k in gb.attrs and not same(ga.attrs[k], gb.attrs[k]):
            bad.append(f"{name}@{k}")
    if isinstance(ga, h5py.Dataset):
        if not same(ga[()], gb[()]):
            bad.append(name)
    elif set(ga) != set(gb):
        bad.append(f"{name}: members")
    else:
        for k in ga:
            compare(f"{name}/{k}" if name else k)


compare("")
print("checkpoint:", "identical" if not bad else "differs in " + ", ".join(bad), f"(not compared: {sorted(skip)})")
sys.exit(1 if bad else 0)
