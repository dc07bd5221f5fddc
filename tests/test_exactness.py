"""The vectorised models agree cell by cell with the literal transcription (tests/literal.py).

Windows of the real Intel map (picked by looking at the data, world coordinates in metres):

* ``wall``: the long horizontal wall south of the central courtyard, around (5.0, -17.6),
  with the corridor below it (hits and pass-throughs);
* ``open``: open floor around (-4.0, -18.25), free space only at the default settings;
* ``edge``: the east edge of the map: from x = 18.7 m to the last column (x ~ 20 m), around
  y = -20; the farthest end points are at x ~ 19.1 m, so the window holds both cells with
  evidence and untouched cells up to the map's boundary column.

A window is (2h+1) rows by (2h+1) columns of cells around its centre (the edge window spans
to the last column); h is smaller for the expensive settings (all poses within z_max, every
beam) to keep the whole file around two minutes.

With ``nearest_poses=None`` a full package map takes 10-20 s at 0.135 m, so for that option the
package builds only the southern strip y in [-25, -16.5] of the template grid, which holds all
three windows (same x extent, so the east edge is the map's; same cell centres and indices,
checked cell by cell below).

Every cell of every window is compared, alpha and beta (or the 7 semantic alphas), to 1e-9.
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import evidence, intel_map, intel_raw
from literal import (CONTINUOUS, FREE, MODELS, SEMANTIC, cell_grid, literal_counts,
                     poses_from_struct, scans_from_cell)

GRIDS = (0.135, 0.27, 0.5)
ATOL = 1e-9

WINDOW_CENTRE = {"wall": (5.0, -17.6), "open": (-4.0, -18.25), "edge": (19.0, -20.0)}
EDGE_X0 = 18.7  # the edge window spans from here to the map's last column
SOUTH_STRIP = (-25.0, -16.5)  # range_y of the package maps built with nearest_poses=None


def window_ids(grid_size: float, name: str, half: int) -> list[int]:
    """Cell indices (i = iy * nx + ix) of a window of the template grid."""
    cells, nx, ny = cell_grid(grid_size)
    xs, ys = cells[:nx, 0], cells[::nx, 1]
    cx, cy = WINDOW_CENTRE[name]
    ix0 = int(np.argmin(np.abs(xs - cx)))
    iy0 = int(np.argmin(np.abs(ys - cy)))
    iys = range(max(0, iy0 - half), min(ny, iy0 + half + 1))
    if name == "edge":
        ixs = range(int(np.argmin(np.abs(xs - EDGE_X0))), nx)
    else:
        ixs = range(max(0, ix0 - half), min(nx, ix0 + half + 1))
    return [iy * nx + ix for iy in iys for ix in ixs]


DEFAULT_STEP = 0.1
# free-sample spacing equal to the grid size, as the handout's FAQ suggests
STEP_CASES = (("continuous_CSM", 0.5, 16, "nearest"), ("continuous_S_CSM", 0.135, 16, "nearest"),
              ("continuous_CSM", 0.27, 16, "all"))


def _cases():
    """(model, grid, nearest_poses, beams, window, half, sample_step) with readable ids."""
    cases = []
    for model in MODELS:
        for g in GRIDS:
            for nn, half in ((16, 3), (None, 1)):
                for w in WINDOW_CENTRE:
                    cases.append((model, g, nn, "nearest", w, half, DEFAULT_STEP))
            if model in CONTINUOUS:
                for w in WINDOW_CENTRE:
                    cases.append((model, g, 16, "all", w, 2, DEFAULT_STEP))
        if model in CONTINUOUS:
            for w in WINDOW_CENTRE:
                cases.append((model, 0.27, None, "all", w, 1, DEFAULT_STEP))
    for model, g, nn, beams in STEP_CASES:
        for w in WINDOW_CENTRE:
            cases.append((model, g, nn, beams, w, 3 if beams == "nearest" else 2, g))
    return [pytest.param(*c, id=f"{c[0]}-g{c[1]}-nn{c[2]}-{c[3]}-{c[4]}"
                         + ("" if c[6] == DEFAULT_STEP else f"-step{c[6]}")) for c in cases]


_converted = {}


def _data(semantic: bool):
    """Poses and polar scans for the literal code, converted once."""
    if semantic not in _converted:
        pose, scan = intel_raw(semantic)
        _converted[semantic] = (pose, scan, poses_from_struct(pose), scans_from_cell(scan))
    return _converted[semantic]


def _hit_free(model, lit):
    """Per cell (hit evidence, free evidence) of a literal result."""
    if model in SEMANTIC:
        return lit["alpha"][:, :FREE].sum(axis=1), lit["alpha"][:, FREE]
    return lit["alpha"][:, 0], lit["beta"][:, 0]


@pytest.mark.parametrize("model, grid_size, nearest_poses, beams, window, half, sample_step",
                         _cases())
def test_window_matches_literal(model, grid_size, nearest_poses, beams, window, half,
                                sample_step):
    semantic = model in SEMANTIC
    pose, scan, poses, scans = _data(semantic)
    ids = window_ids(grid_size, window, half)
    lit = literal_counts(model, pose, scan, ids, grid_size=grid_size,
                         nearest_poses=nearest_poses, beams=beams, sample_step=sample_step,
                         poses=poses, scans=scans)

    # the comparison is not vacuous: the window holds the evidence it was chosen for
    hit, free = _hit_free(model, lit)
    if window == "wall":
        assert (hit > 0).any() and (free > 0).any(), "wall window without hits or free space"
    elif window == "open":
        assert (free > 0).mean() >= 0.8 and free.sum() > hit.sum(), "open window not free"
    else:
        touched = (hit > 0) | (free > 0)
        assert touched.any() and not touched.all(), "edge window should be partly observed"
        _, nx, _ = cell_grid(grid_size)
        assert any(i % nx == nx - 1 for i in ids), "edge window misses the last column"

    obj = intel_map(model, grid_size, nearest_poses, beams,
                    SOUTH_STRIP if nearest_poses is None else None,
                    None if sample_step == DEFAULT_STEP else sample_step)
    np.testing.assert_array_equal(np.asarray(obj.map["occMap"].data)[ids], lit["cells"])
    alpha, beta = evidence(obj, semantic)
    bad = []
    for row, i in enumerate(ids):
        if not np.allclose(alpha[i], lit["alpha"][row], rtol=0, atol=ATOL):
            bad.append(f"cell {i} at {tuple(lit['cells'][row])}: alpha package "
                       f"{alpha[i].tolist()} literal {lit['alpha'][row].tolist()}")
        if not semantic and not np.allclose(beta[i], lit["beta"][row], rtol=0, atol=ATOL):
            bad.append(f"cell {i} at {tuple(lit['cells'][row])}: beta package "
                       f"{beta[i].tolist()} literal {lit['beta'][row].tolist()}")
    assert not bad, f"{len(bad)} disagreements in {len(ids)} cells:\n" + "\n".join(bad[:20])


@pytest.mark.parametrize("grid_size", GRIDS, ids=lambda g: f"g{g}")
def test_cell_centres_are_the_template_grid(grid_size):
    cells, nx, ny = cell_grid(grid_size)
    obj = intel_map("CSM", grid_size, 16, "nearest")
    assert obj.map["size"] == nx * ny
    np.testing.assert_array_equal(np.asarray(obj.map["occMap"].data), cells)


@pytest.mark.parametrize("model, nearest_poses, beams", [
    ("continuous_CSM", 16, "all"),
    ("continuous_S_CSM", 16, "all"),
    ("continuous_CSM", None, "nearest"),
], ids=lambda v: str(v))
def test_pruning_changes_nothing(model, nearest_poses, beams):
    """The literal code's pruning only skips points farther than l: it changes no count."""
    semantic = model in SEMANTIC
    pose, scan, poses, scans = _data(semantic)
    ids = window_ids(0.27, "wall", 0)[:1] + window_ids(0.27, "edge", 0)[:2]
    kw = dict(grid_size=0.27, nearest_poses=nearest_poses, beams=beams, poses=poses, scans=scans)
    fast = literal_counts(model, pose, scan, ids, prune=True, **kw)
    slow = literal_counts(model, pose, scan, ids, prune=False, **kw)
    assert fast["alpha"].sum() > 0
    np.testing.assert_allclose(fast["alpha"], slow["alpha"], rtol=0, atol=1e-12)
    if not semantic:
        np.testing.assert_allclose(fast["beta"], slow["beta"], rtol=0, atol=1e-12)
