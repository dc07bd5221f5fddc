"""Property-based tests of the 3D config files and the 2D constructor keywords: any TOML file and
any keyword value gives a checked setting and a finite map, or a one-line refusal."""
from __future__ import annotations

import atexit
import math
import shutil
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import event, given, settings
from hypothesis import strategies as st

from test_fuzz_settings import examples, refused_or

from hw4.bki.config import (MAX_CLASSES, MAX_SCALE, MIN_LENGTH, MIN_PRIOR, BKIConfig, check_method,
                            load_config)
from hw4.bki.pipeline import map_scans
from hw4.bki.scan import Scan
from hw4.ogm_CSM import ogm_CSM
from hw4.ogm_S_CSM import ogm_S_CSM
from hw4.ogm_continuous_CSM import ogm_continuous_CSM
from hw4.ogm_continuous_S_CSM import ogm_continuous_S_CSM

_DIR = Path(tempfile.mkdtemp(prefix="fuzz-config-"))
atexit.register(shutil.rmtree, _DIR, True)
KEYS = [f.name for f in BKIConfig.__dataclass_fields__.values()]
NUMBERS = st.one_of(
    st.sampled_from([0, 1, 2, 3, 4, 20, -1, 1000, 10**9, 2**63 - 1, 0.0, -0.5, 0.05, 0.1, 0.3, 0.5,
                     1.0, 100.0, 1e6, 1e-6, 1e-20, 1e308, 1e-320, math.inf, -math.inf, math.nan]),
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**20, 10**20))


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else "-inf" if v == -math.inf
                                            else repr(v))
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return str(v)


PLAUSIBLE = st.sampled_from([0.1, 0.2, 0.3, 0.5, 1.0, 2.0, 4, 3, 10, 20, -1.0, 8.0, 0.05, 0.09])
VALUES = st.one_of(PLAUSIBLE, PLAUSIBLE, PLAUSIBLE, NUMBERS, st.booleans(),
                   st.sampled_from(["labels", "", "x", "predictions"]),
                   st.lists(st.integers(0, 3), max_size=2))


@st.composite
def config_files(draw) -> bytes:
    entries = draw(st.lists(st.tuples(st.sampled_from(["", "map", "training", "kernel", "data",
                                                       "map"]),
                                      st.sampled_from(KEYS + ["unknown", "Resolution"]),
                                      VALUES), max_size=4))
    top = [f"{k} = {toml_value(v)}" for t, k, v in entries if not t]
    tables: dict = {}
    for t, k, v in entries:
        if t:
            tables.setdefault(t, []).append(f"{k} = {toml_value(v)}")
    text = "\n".join(top + [f"[{t}]\n" + "\n".join(lines) for t, lines in tables.items()]) + "\n"
    raw = text.encode()
    if draw(st.integers(0, 10)) == 0:  # byte-level damage: not UTF-8, not TOML
        i = draw(st.integers(0, len(raw)))
        raw = raw[:i] + draw(st.sampled_from([b"\xff", b"\xe9", b"[", b"=", b"\x00", b"\n[map]\n"])) \
            + raw[i:]
    return raw


def check_bounds(cfg: BKIConfig):
    """The documented ranges, checked independently of the loader."""
    for name in ("resolution", "ds_resolution", "ell"):
        assert MIN_LENGTH <= getattr(cfg, name) < math.inf
    assert 0 < cfg.free_resolution < math.inf and 0 < cfg.var_thresh < math.inf
    assert 0 < cfg.sf2 <= MAX_SCALE and MIN_PRIOR <= cfg.prior <= MAX_SCALE
    assert math.isfinite(cfg.max_range)
    assert isinstance(cfg.num_class, int) and 2 <= cfg.num_class <= MAX_CLASSES
    assert isinstance(cfg.scans, int) and cfg.scans >= 0
    assert isinstance(cfg.labels, str) and cfg.labels


def tiny_scan(num_class):
    rng = np.random.default_rng(1)
    pts = rng.uniform(-2, 2, (30, 3))
    return Scan(pts, rng.integers(1, max(2, min(num_class, 4)), 30), np.zeros(3), "tiny")


def cheap(cfg: BKIConfig, method: str) -> bool:
    """Small enough to map in the fuzz loop (the work grows with these ratios)."""
    side = 2 * math.floor(cfg.ell / cfg.resolution + 0.5) + 1 if method == "sbki" else 1
    return (30 * 4 / cfg.free_resolution < 2e4 and 60 * side ** 3 * cfg.num_class < 2e6
            and cfg.ds_resolution >= 1e-3)


@settings(max_examples=examples(300))
@given(config_files(), st.sampled_from([None, "toy", "semantickitti"]),
       st.sampled_from(["sbki", "scsm"]))
def test_config_file_is_checked_and_maps_finite_or_refused(raw, defaults, method):
    path = _DIR / "c.toml"
    path.write_bytes(raw)
    cfg = refused_or(lambda: load_config(path, defaults=defaults))
    if cfg is None:
        return
    check_bounds(cfg)
    if refused_or(lambda: check_method(cfg, method) or True) is None:
        assert method == "sbki"
        assert (2 * math.floor(cfg.ell / cfg.resolution + 0.5) + 1) ** 3 > 1 << 20
        return
    if not cheap(cfg, method):
        return
    steps = refused_or(lambda: list(map_scans([lambda: tiny_scan(cfg.num_class)], cfg, method)))
    event("mapped" if steps else "map refused")
    if steps:
        view = steps[-1].map.view()
        assert np.all(np.isfinite(view.probs)) and np.all(np.isfinite(view.variance))
        if len(view):
            np.testing.assert_allclose(view.probs.sum(axis=1), 1.0)


# --------------------------------------------------------------------------- 2D keywords

KEYWORD_VALUES = st.one_of(PLAUSIBLE, PLAUSIBLE, NUMBERS, st.none(), st.booleans(),
                           st.sampled_from(["133", "ab", "nearest", "all", "", [1, 2], [-15, 0, 20],
                                            [-3, 3], [3, -3], [0, math.inf], (-4.0, 4.0),
                                            np.float32(0.5), np.int64(16), np.array([1.0, 2.0]),
                                            1 + 2j]))
PARAMS = ["grid_size", "range_x", "range_y", "z_max", "n_beams", "nearest_poses", "prior_alpha",
          "progress", "sigma", "l", "sample_step", "beams", "num_classes", "free_samples", "other"]


def scene(semantic):
    poses = np.array([[0.0, 0.0, 0.0], [0.5, 0.2, 0.4]])
    ang = np.linspace(-np.pi, np.pi, 40, endpoint=False)
    scans = [np.vstack([2.5 * np.cos(ang), 2.5 * np.sin(ang), 1 + np.arange(40) % 6]) for _ in poses]
    return poses, scans if semantic else [s[:2] for s in scans]


@settings(max_examples=examples(300))
@given(st.sampled_from([ogm_CSM, ogm_S_CSM, ogm_continuous_CSM, ogm_continuous_S_CSM]),
       st.dictionaries(st.sampled_from(PARAMS), KEYWORD_VALUES, max_size=2))
def test_template_keywords_checked_and_maps_finite_or_refused(cls, kw):
    kw = {"range_x": [-3, 3], "range_y": [-3, 3], "grid_size": 0.5, **kw}
    m = refused_or(lambda: cls(**kw))
    if m is None:
        return
    g = m.grid_size
    cells = ((m.range_x[1] - m.range_x[0]) / g + 2) * ((m.range_y[1] - m.range_y[0]) / g + 2)
    step = getattr(m, "sample_step", 1.0)
    if cells > 5e4 or (m.continuous and (getattr(m, "l", 0) / step > 200 or 5 / step > 2e4
                                         or m.l / g > 50)):
        return  # a valid but slow setting: the refusals of slow settings are tested elsewhere

    def build():
        m.construct_map(*scene(cls.semantic))
        m.build_ogm()
        return m
    built = refused_or(build)
    event("built" if built is not None else "build refused")
    if built is not None:
        mean, var = np.asarray(built.map["mean"]), np.asarray(built.map["variance"])
        assert np.all(np.isfinite(mean)) and np.all(np.isfinite(var)) and np.all(var >= 0)
        assert np.all((mean >= 0) & (mean <= 1))
