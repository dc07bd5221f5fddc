"""Write a final 3D semantic map: every voxel with evidence as CSV, occupied voxels as a PLY cloud.

``voxels.csv``: one row per voxel with evidence, columns ``x, y, z`` (voxel centre [m], world
frame), ``state`` (unknown / free / occupied, with ``var_thresh``), ``class`` (most likely, 0 =
free), ``variance`` (of that class), then ``p_0 .. p_{K-1}``.

``voxels.ply``: ASCII PLY point cloud of the occupied voxels' centres [m] with ``red green blue``
(class colour), ``label`` and ``variance`` properties; CloudCompare and MeshLab open it.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .palette import class_colors
from .voxelmap import MapView

STATE_NAMES = np.array(["unknown", "free", "occupied"])


def write_csv(view: MapView, path) -> Path:
    """Write every voxel of ``view`` to ``path`` (see the module docstring); return the path."""
    path = Path(path)
    K = view.probs.shape[1]
    header = "x,y,z,state,class,variance," + ",".join(f"p_{k}" for k in range(K))
    with open(path, "w") as f:
        f.write(header + "\n")
        for s in range(0, len(view), 8192):  # in slices: the text of all rows at once took ~0.8 GB
            sl = slice(s, s + 8192)
            cols = [np.char.mod("%.4f", view.centres[sl, a]) for a in range(3)]
            cols += [STATE_NAMES[view.state[sl]], view.cls[sl].astype(str),
                     np.char.mod("%.6g", view.variance[sl])]
            cols += [np.char.mod("%.6g", view.probs[sl, k]) for k in range(K)]
            f.write("\n".join(",".join(r) for r in np.stack(cols, axis=1).tolist()) + "\n")
    return path


def write_ply(view: MapView, path, mask: np.ndarray | None = None) -> Path:
    """Write the occupied voxels (or those selected by ``mask``) as a coloured ASCII PLY cloud."""
    path = Path(path)
    sel = view.occupied if mask is None else np.asarray(mask, bool)
    xyz, cls, var = view.centres[sel], view.cls[sel], view.variance[sel]
    rgb = class_colors(view.probs.shape[1])[cls]
    lines = ["ply", "format ascii 1.0",
             "comment 3D semantic map (hw4.bki): occupied voxel centres [m], world frame",
             f"comment voxel size {view.resolution} m",
             f"element vertex {len(xyz)}",
             "property float x", "property float y", "property float z",
             "property uchar red", "property uchar green", "property uchar blue",
             "property int label", "property float variance", "end_header"]
    table = np.empty((len(xyz), 8), dtype=object)
    table[:, :3], table[:, 3:6], table[:, 6], table[:, 7] = xyz, rgb, cls, var
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
        np.savetxt(f, table, fmt=["%.4f"] * 3 + ["%d"] * 4 + ["%.6g"])
    return path
