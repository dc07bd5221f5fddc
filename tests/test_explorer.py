"""The live explorer of Tasks 2 and 4 (hw4.book.explorer).

* ``cell_evidence``: a single cell's contributions, summed, are the map's alpha and beta (class
  counts) of that cell, on every cell of a 0.5 m map and on sampled cells of other settings;
* the explorer driven in-process: sliders set, a click simulated through the ipyevents handler,
  the redrawn map equal to a fresh ``construct_map`` / ``build_ogm`` with those parameters, the
  figure's pixels the map's values, the evidence table the map's cell;
* the explorer in a real Jupyter kernel (jupyter_client): the widgets open their comms, a slider
  moved and a click sent as the browser sends them (comm messages), the kernel redraws and the
  new image reaches the front end.
"""
from __future__ import annotations

import io
import json
import re

import numpy as np
import pytest

from conftest import intel_raw, model_class

ipywidgets = pytest.importorskip("ipywidgets")

from hw4.book import explorer as ex  # noqa: E402
from hw4.core.errors import InputError  # noqa: E402
from hw4.core.sensor import BeamTable  # noqa: E402

CONT = {2: "continuous_CSM", 4: "continuous_S_CSM"}
RTOL = 1e-12   # the map sums the same weights in another order


def fresh_map(task, **params):
    """The map of ``task`` as a student builds it: loadmat's structures, construct_map, build_ogm."""
    ogm = model_class(CONT[task])(**params)
    ogm.construct_map(*intel_raw(task == 4))
    ogm.build_ogm()
    return ogm


def map_alpha(ogm):
    """(n_cells, K) concentrations of a built map: [alpha, beta] or the Dirichlet's."""
    return ogm.map["alpha"] if ogm.semantic else np.hstack([ogm.map["alpha"], ogm.map["beta"]])


def check_cells(ogm, cells):
    table = BeamTable.from_scans(ogm.scans)
    for i in cells:
        e = ex.cell_evidence(ogm, int(i), table)
        tot = e.totals()
        np.testing.assert_allclose(tot, ogm.counts[i], rtol=RTOL, atol=0,
                                   err_msg=f"cell {i} at {e.centre}")
        np.testing.assert_allclose(ogm.prior_alpha + tot, map_alpha(ogm)[i], rtol=RTOL, atol=0)
        assert np.all(e.distance < ogm.l) and np.all(e.weight >= 0)   # k rounds to 0 just inside l
        assert set(np.unique(e.pose)) <= set(e.considered.tolist())


@pytest.mark.parametrize("task, stride", [(2, 1), (4, 3)])
def test_cell_evidence_sums_to_every_cell_of_the_map(task, stride):
    ogm = fresh_map(task, grid_size=0.5)
    check_cells(ogm, range(0, ogm.grid.n_cells, stride))   # 5,041 cells (every third for task 4)


@pytest.mark.parametrize("task, params, n", [
    (2, dict(grid_size=0.27, l=0.3, sigma=0.5, sample_step=0.05, prior_alpha=0.1), 150),
    (4, dict(grid_size=0.135), 150),                                   # the homework's map
    (2, dict(grid_size=0.5, nearest_poses=None, l=0.4), 40),           # every pose within z_max
    (4, dict(grid_size=0.35, nearest_poses=4, sample_step=0.2, l=0.15), 150),
])
def test_cell_evidence_sums_to_sampled_cells(task, params, n):
    ogm = fresh_map(task, **params)
    observed = np.flatnonzero(ogm.observed)
    rng = np.random.default_rng(23)
    cells = rng.choice(observed, n, replace=False)
    cells = np.concatenate([cells, rng.choice(np.flatnonzero(~ogm.observed), 10, replace=False)])
    check_cells(ogm, cells)


def test_cell_evidence_lists_an_observation_by_hand():
    """One robot, one beam straight ahead to (1, 0) m: the cell at the end point gets k(0) to
    alpha, and the free samples 0.1 m apart within l = 0.2 m of it (at 0.9 and 0.8 m; 1.0 m is
    the end point, not a free sample) their k(d) to beta."""
    from hw4.core.kernel import sparse_kernel
    cls = model_class("continuous_CSM")
    ogm = cls(grid_size=0.1, range_x=[-1, 2], range_y=[-1, 1])
    ogm.construct_map(np.array([[0.0, 0.0, 0.0]]), [np.array([[1.0], [0.0]])])
    ogm.build_ogm()
    i = ex.cell_at(ogm, 1.0, 0.0)
    e = ex.cell_evidence(ogm, i)
    (row,) = e.by_beam()
    assert (row["pose"], row["beam"], row["end_column"], row["free_samples"]) == (0, 0, 0, 2)
    assert row["range"] == 1.0 and row["bearing_diff"] == 0.0
    assert row["end_distance"] == pytest.approx(0.0, abs=1e-12)
    assert row["end_weight"] == pytest.approx(0.1, abs=1e-12)
    assert row["free_weight"] == pytest.approx(float(sparse_kernel(0.1)), abs=1e-12)  # k(0.2) = 0
    assert sorted(e.sample[e.kind == ex.FREE].tolist()) == [8, 9]
    np.testing.assert_allclose(e.totals(), ogm.counts[i], rtol=RTOL)


def test_cell_evidence_refuses_what_it_does_not_cover():
    with pytest.raises(InputError, match="continuous models"):
        ex.cell_evidence(model_class("CSM")(grid_size=0.5), 0)
    with pytest.raises(InputError, match="beams='nearest'"):
        ex.cell_evidence(model_class("continuous_CSM")(grid_size=0.5, beams="all"), 0)
    with pytest.raises(InputError, match="construct_map"):
        ex.cell_evidence(model_class("continuous_CSM")(grid_size=0.5), 0)
    ogm = fresh_map(2, grid_size=0.5)
    for bad in (-1, ogm.grid.n_cells, 1.5, True):
        with pytest.raises(InputError, match="cell must be an index"):
            ex.cell_evidence(ogm, bad)
    with pytest.raises(InputError, match="outside the map"):
        ex.cell_at(ogm, 100.0, 0.0)


# ------------------------------------------------------------------------- the explorer in-process

def panel_pixel(panel, x, y):
    """(column, row) of the PNG pixel at the world point (x, y) [m] on a full-map panel, from the
    layout constants alone: the 35 m square map fills the square panel."""
    x0, y0, w, h = ex.PANELS[panel]
    px = x0 + (x + 15.0) / 35.0 * w
    py = ex.FIG_PX[1] - (y0 + (y + 25.0) / 35.0 * h)
    return px, py


def decode(png):
    from matplotlib.image import imread
    return imread(io.BytesIO(png), format="png")[..., :3]


def segment_distance(p, a, b):
    """Distance of points p (N, 2) to the segment a-b [m]."""
    ab = b - a
    t = np.clip(((p - a) @ ab) / max(ab @ ab, 1e-300), 0, 1)
    return np.linalg.norm(p - (a + t[:, None] * ab), axis=1)


def check_mean_panel(e):
    """The P(occupied) panel shows the map's means (gray_r: 1 - mean), away from the overlays."""
    ogm = e.ogm
    img = decode(e.png)
    cells = ogm.grid.cells
    clear = ogm.observed.copy()
    for r in e.evidence.by_beam()[:ex.MAX_BEAMS_DRAWN]:
        a = ogm.poses[r["pose"], :2]
        clear &= segment_distance(cells, a, np.array(e._end_point(r))) > 0.7
    for t in e.evidence.considered:
        clear &= np.linalg.norm(cells - ogm.poses[t, :2], axis=1) > 0.7
    clear &= np.linalg.norm(cells - e.evidence.centre, axis=1) > 1.0
    idx = np.flatnonzero(clear)
    assert len(idx) > 500
    got, want = [], []
    for i in idx:
        px, py = panel_pixel(0, *cells[i])
        got.append(img[int(py), int(px)].mean())
        want.append(1.0 - ogm.map["mean"][i, 0])
    np.testing.assert_allclose(got, want, atol=3 / 255)


def test_explorer_sliders_redraw_the_map_built_with_those_parameters():
    e = ex.Explorer(task=2)
    assert e.params == dict(grid_size=0.5, l=0.2, sigma=0.1, prior_alpha=1e-3, sample_step=0.1)
    check_mean_panel(e)
    first = e.png
    # the front end sets one value at a time; every change redraws
    e.l.value = 0.3
    e.sigma.value = 0.5
    e.prior.value = 0.01
    e.step.value = 0.05
    e.grid.value = 0.27
    want = fresh_map(2, grid_size=0.27, l=0.3, sigma=0.5, prior_alpha=0.01, sample_step=0.05)
    for key in ("alpha", "beta", "mean", "variance"):
        np.testing.assert_array_equal(e.ogm.map[key], want.map[key])
    assert e.png != first
    check_mean_panel(e)
    assert e.seconds["build"] >= 0 and e.seconds["draw"] > 0


def test_explorer_click_picks_the_cell_and_tabulates_its_evidence():
    e = ex.Explorer(task=2, grid_size=0.5)
    assert e.events is not None, "ipyevents is in the book extra"
    x, y = -9.0, -18.5                         # a wall cell with hits and free samples
    px, py = panel_pixel(1, x + 0.1, y - 0.1)  # on the variance panel, inside that cell
    e.events._handle_mouse_msg(None, {"type": "click", "dataX": round(px), "dataY": round(py)},
                               None)           # what ipyevents calls for the browser's click
    i = ex.cell_at(e.ogm, x, y)
    assert e.evidence.cell == i
    assert (e.x.value, e.y.value) == (x, y)     # the cell sliders show the picked centre
    alpha, beta = e.ogm.map["alpha"][i, 0], e.ogm.map["beta"][i, 0]
    assert alpha > 0.3 and beta > 0.3
    np.testing.assert_allclose(e.ogm.prior_alpha + e.evidence.totals(), [alpha, beta], rtol=RTOL)
    html = e.table_html()
    last = re.findall(r"<tr><td><b>the map's cell</b></td><td><b>([^<]*)</b></td><td><b>([^<]*)</b>",
                      html)
    assert last == [(f"{alpha:.6g}", f"{beta:.6g}")]
    rows = e.evidence.by_beam()
    assert html.count("<tr>") == len(rows) + 1 + 5   # header, beams, sum table's header and 4
    assert f"Cell {i}</b> at (-9.000, -18.500) m" in html
    # a click outside both maps (the colour bar, the cell panel) picks nothing new
    for px, py in ((325, 150), (900, 150), (5, 5)):
        e.on_click({"type": "click", "dataX": px, "dataY": py})
        assert e.evidence.cell == i
    e.on_click({"type": "mousemove", "dataX": 100, "dataY": 100})
    assert e.evidence.cell == i
    # the cell sliders pick too, and a grid change keeps the point
    e.set(x=-2.0, y=-18.0)
    assert e.evidence.cell == ex.cell_at(e.ogm, -2.0, -18.0)
    e.set(grid=0.27)
    assert np.allclose(e.evidence.centre, e.ogm.grid.cells[ex.cell_at(e.ogm, -2.0, -18.0)])


def test_explorer_semantic_table_has_the_class_counts():
    e = ex.Explorer(task=4, cell=(-9.0, -18.5))
    i = e.evidence.cell
    alpha = e.ogm.map["alpha"][i]
    np.testing.assert_allclose(e.ogm.prior_alpha + e.evidence.totals(), alpha, rtol=RTOL)
    html = e.table_html()
    for name in ("north rooms", "hallways", "free"):
        assert f"<th>{name}</th>" in html
    cells = re.findall(r"<tr><td><b>the map's cell</b></td>(.*?)</tr>", html)[0]
    assert re.findall(r"<b>([^<]*)</b>", cells) == [f"{v:.6g}" for v in alpha]
    want = fresh_map(4, grid_size=0.5)
    np.testing.assert_array_equal(e.ogm.map["alpha"], want.map["alpha"])
    assert "most likely class" not in repr(e) and "explorer" in repr(e)
    legend = e._legend_html()   # the maps' legend text: the data's label and the handout's name
    assert "label 1 (north rooms)" in legend and "label 6 (hallways)" in legend


def test_explorer_refuses_bad_settings():
    with pytest.raises(InputError, match="task 2 or 4"):
        ex.Explorer(task=1)
    with pytest.raises(InputError, match="grid_size must be one of"):
        ex.Explorer(task=2, grid_size=0.3)
    with pytest.raises(InputError, match="outside the map"):
        ex.Explorer(task=2, cell=(50.0, 0.0))
    e = ex.Explorer(task=2)
    with pytest.raises(InputError, match="unknown slider"):
        e.set(colour=1)


def test_explorer_plain_text_is_deterministic():
    """nbval compares the cell's text/plain (it skips the widget's random model id)."""
    e = ex.Explorer(task=2)
    bundle = e._repr_mimebundle_()
    assert bundle["text/plain"] == ("<ogm_continuous_CSM explorer: grid 0.5 m, l 0.2 m, sigma0 "
                                    "0.1, prior 0.001, free step 0.1 m (live in Jupyter)>")
    assert bundle["application/vnd.jupyter.widget-view+json"]["model_id"] == e.widget.model_id


def test_still_command(tmp_path):
    out = tmp_path / "still.png"
    assert ex.main(["--task", "2", "--still", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert decode(out.read_bytes()).shape == (ex.FIG_PX[1], ex.FIG_PX[0], 3)
    assert ex.main(["--task", "2", "--still", str(tmp_path / "no" / "such" / "dir.png")]) == 2


# ------------------------------------------------------------------------ the explorer in a kernel

def test_explorer_in_a_jupyter_kernel():
    """A real kernel: the widgets' comms open, the front end's messages (a slider released, a
    click on the map) reach the explorer, and the redrawn image goes back to the front end."""
    from jupyter_client.manager import start_new_kernel
    km, kc = start_new_kernel(kernel_name="python3")
    try:
        seen = []   # every iopub message, in order

        def run(code, timeout=120):
            """Execute; return (stdout, the iopub messages) once the kernel is idle."""
            msg_id = kc.execute(code)
            out, msgs = [], []
            while True:
                m = kc.get_iopub_msg(timeout=timeout)
                seen.append(m)
                if m["parent_header"].get("msg_id") != msg_id:
                    continue
                msgs.append(m)
                if m["msg_type"] == "stream":
                    out.append(m["content"]["text"])
                if m["msg_type"] == "error":
                    raise AssertionError("\n".join(m["content"]["traceback"]))
                if m["msg_type"] == "status" and m["content"]["execution_state"] == "idle":
                    return "".join(out), msgs

        def send(comm_id, data):
            """A comm message from the front end, as the browser's widget manager sends it."""
            msg = kc.session.msg("comm_msg", {"comm_id": comm_id, "data": data})
            kc.shell_channel.send(msg)
            return msg["header"]["msg_id"]

        _, msgs = run("from hw4.book.explorer import Explorer\nexp = Explorer(task=2)\nexp")
        models = {m["content"]["comm_id"]: m["content"]["data"]["state"]
                  for m in msgs if m["msg_type"] == "comm_open"}
        shown = [m for m in msgs if m["msg_type"] == "execute_result"]
        view = shown[0]["content"]["data"]["application/vnd.jupyter.widget-view+json"]
        assert models[view["model_id"]]["_model_name"] == "VBoxModel"
        assert shown[0]["content"]["data"]["text/plain"].startswith("<ogm_continuous_CSM explorer")

        def comm(model, **state):
            return next(c for c, s in models.items() if s["_model_name"] == model
                        and all(s.get(k) == v for k, v in state.items()))

        l_slider = comm("SelectionSliderModel", description="l [m]")
        image = comm("ImageModel")
        events = comm("EventModel")
        # release the l slider at 0.3 m: the browser sends the new index
        moved = send(l_slider, {"method": "update", "state": {"index": ex.L_CHOICES.index(0.3)},
                        "buffer_paths": []})
        # click on the map at (-9.1, -18.4) m (the cell at (-9, -18.5) m at 0.5 m)
        x0, y0, w, h = ex.PANELS[0]
        px = x0 + (-9.1 + 15) / 35 * w
        py = ex.FIG_PX[1] - (y0 + (-18.4 + 25) / 35 * h)
        clicked = send(events, {"method": "custom", "content": {"type": "click", "dataX": round(px),
                                                      "dataY": round(py)}})
        out, msgs = run(
            "import json, numpy as np\n"
            "from hw4.tasks import load_task_data\n"
            "from hw4.ogm_continuous_CSM import ogm_continuous_CSM\n"
            "d = load_task_data(2)\n"
            "ref = ogm_continuous_CSM(grid_size=0.5, l=0.3)\n"
            "ref.construct_map(d.poses, [s[:2] for s in d.scans]); ref.build_ogm()\n"
            "i = exp.evidence.cell\n"
            "print(json.dumps(dict(l=exp.l.value, same=all(np.array_equal(exp.ogm.map[k], ref.map[k])"
            " for k in ('alpha', 'beta', 'mean', 'variance')), cell=i,"
            " centre=exp.ogm.grid.cells[i].tolist(),"
            " sums=(exp.ogm.prior_alpha + exp.evidence.totals()).tolist(),"
            " map=[exp.ogm.map['alpha'][i, 0], exp.ogm.map['beta'][i, 0]])))")
        got = json.loads(out)
        assert got["l"] == 0.3 and got["same"]
        assert got["centre"] == [-9.0, -18.5]
        np.testing.assert_allclose(got["sums"], got["map"], rtol=RTOL)
        # the redraws reached the front end: the image's new value, sent as a binary buffer
        # while the kernel handled the slider's and the click's messages (their children)
        for parent in (moved, clicked):
            pushed = [m for m in seen if m["parent_header"].get("msg_id") == parent
                      and m["msg_type"] == "comm_msg" and m["content"]["comm_id"] == image]
            assert pushed, "no new image sent to the front end"
            data = pushed[-1]["content"]["data"]
            assert data["method"] == "update" and ["value"] in data["buffer_paths"]
            assert bytes(pushed[-1]["buffers"][0])[:8] == b"\x89PNG\r\n\x1a\n"
    finally:
        kc.stop_channels()
        km.shutdown_kernel(now=True)
