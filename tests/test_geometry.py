"""Grid and sensor geometry against the template's conventions."""
import numpy as np
import pytest

from hw4.core.grid import Grid
from hw4.core.sensor import BeamTable, wrap_to_pi


def template_wrap(phase):
    """The course template's wrapToPI, for one value."""
    x = np.remainder(phase, 2 * np.pi)
    while abs(x) > np.pi:
        x -= 2 * np.pi * np.sign(x)
    return x


@pytest.mark.parametrize("g", [0.135, 0.27, 0.5])
def test_cells_in_template_order_and_round_trip(g):
    grid = Grid(g)
    x = np.arange(-15, 20 + g, g)
    y = np.arange(-25, 10 + g, g)
    X, Y = np.meshgrid(x, y)
    np.testing.assert_array_equal(grid.cells, np.column_stack([X.ravel(), Y.ravel()]))
    # world -> cell index round trip over every cell
    np.testing.assert_array_equal(grid.nearest_cell(grid.cells), np.arange(grid.n_cells))
    assert grid.nearest_cell([[-100.0, 0.0]])[0] == -1


def test_wrap_matches_template():
    a = np.concatenate([np.linspace(-20, 20, 2001), [np.pi, -np.pi, 3 * np.pi, 0.0, -0.0]])
    np.testing.assert_array_equal(wrap_to_pi(a), [template_wrap(v) for v in a])


def test_nearest_beam_matches_argmin_with_ties_and_duplicates():
    rng = np.random.default_rng(1)
    scans = []
    for t in range(40):
        n = rng.integers(5, 200)
        ang = np.sort(rng.uniform(-np.pi, np.pi, n)) if t % 3 else np.linspace(-np.pi / 2, np.pi / 2, n)
        if t % 5 == 0:  # duplicated bearings with different ranges
            ang[1::4] = ang[::4][: len(ang[1::4])]
        rng.shuffle(ang)
        r = rng.uniform(0.5, 10, n)
        scans.append(np.vstack([r * np.cos(ang), r * np.sin(ang)]))
    table = BeamTable.from_scans(scans)
    pose = rng.integers(0, 40, 20000)
    phi = rng.uniform(-np.pi, np.pi, 20000)
    phi[:200] = table.bearings[rng.integers(0, len(table.bearings), 200)]  # exact hits
    phi[200:210] = np.pi
    got = table.nearest(pose, phi)
    for i in range(len(pose)):
        b = np.arange(table.first[pose[i]], table.first[pose[i] + 1])
        diffs = np.abs([template_wrap(th - phi[i]) for th in table.bearings[b]])
        assert got[i] == b[np.nanargmin(diffs)], i
