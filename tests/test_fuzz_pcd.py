"""Property-based tests of the PCD reader: generated files read back exactly, mutated files are
read consistently with their header or refused in one line."""
from __future__ import annotations

import atexit
import shutil
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from test_fuzz_settings import examples, refused_or

from hw4.bki.pcd import read_labelled_scan, read_pcd
from hw4.bki.scan import validate_scan

TYPES = {"<f4": ("F", 4), "<f8": ("F", 8), "<u1": ("U", 1), "<u2": ("U", 2), "<u4": ("U", 4),
         "<i1": ("I", 1), "<i2": ("I", 2), "<i4": ("I", 4)}
NASTY = ["nan", "inf", "-inf", "-1", "0", "1", "2", "1e400", "1e-400", "\u00b2", "1.5", "_", "x",
         "label", "F", "U", "I", "8", "99999999999999999999", "ascii", "binary", "1048577", ""]


@st.composite
def clouds(draw):
    """(fields [(name, dtype, count)], {name: values}, n, viewpoint, kind)."""
    n = draw(st.integers(0, 12))
    label_dt = draw(st.sampled_from(["<u4", "<u1", "<i4", "<f4", "<f8"]))
    fields = [("x", draw(st.sampled_from(["<f4", "<f8"])), 1), ("y", "<f4", 1), ("z", "<f4", 1),
              ("label", label_dt, 1)]
    for i in range(draw(st.integers(0, 2))):
        fields.insert(draw(st.integers(0, len(fields))),
                      (draw(st.sampled_from(["_", f"extra{i}"])),
                       draw(st.sampled_from(sorted(TYPES))), draw(st.integers(1, 3))))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    values = []
    for name, dt, c in fields:
        shape = (n,) if c == 1 else (n, c)
        if name == "label":
            v = rng.integers(1, 4, shape).astype(dt)
        elif np.dtype(dt).kind == "f":
            v = rng.uniform(-50, 50, shape).astype(dt)
        else:
            info = np.iinfo(dt)
            v = rng.integers(info.min, int(info.max) + 1, shape, dtype=np.int64).astype(dt)
        values.append(v)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    viewpoint = np.concatenate([rng.uniform(-5, 5, 3).round(3), q])
    return fields, values, n, viewpoint, draw(st.sampled_from(["ascii", "binary"]))


def encode(fields, values, n, viewpoint, kind) -> bytes:
    head = ["# .PCD v0.7", "VERSION 0.7",
            "FIELDS " + " ".join(f for f, _, _ in fields),
            "SIZE " + " ".join(str(TYPES[d][1]) for _, d, _ in fields),
            "TYPE " + " ".join(TYPES[d][0] for _, d, _ in fields),
            "COUNT " + " ".join(str(c) for _, _, c in fields),
            f"WIDTH {n}", "HEIGHT 1", "VIEWPOINT " + " ".join(repr(float(v)) for v in viewpoint),
            f"POINTS {n}", f"DATA {kind}"]
    out = ("\n".join(head) + "\n").encode()
    if kind == "ascii":
        rows = []
        for i in range(n):
            vals = []
            for v in values:
                vals += [repr(float(a)) if v.dtype.kind == "f" else str(int(a))
                         for a in np.atleast_1d(v[i])]
            rows.append(" ".join(vals))
        return out + "".join(r + "\n" for r in rows).encode()
    rec = np.dtype({"names": [f"f{i}" for i in range(len(fields))],
                    "formats": [(d, (c,)) if c > 1 else d for _, d, c in fields]})
    arr = np.zeros(n, rec)
    for i, v in enumerate(values):
        arr[f"f{i}"] = v
    return out + arr.tobytes()


_DIR = Path(tempfile.mkdtemp(prefix="fuzz-pcd-"))
atexit.register(shutil.rmtree, _DIR, True)


def write(data: bytes) -> Path:
    p = _DIR / "scan.pcd"
    p.write_bytes(data)
    return p


@settings(max_examples=examples(250))
@given(clouds())
def test_generated_pcd_reads_back_exactly(cloud):
    fields, values, n, viewpoint, kind = cloud
    p = write(encode(*cloud))
    pcd = read_pcd(p)
    assert len(pcd) == n and pcd.data == kind
    np.testing.assert_array_equal(pcd.viewpoint, viewpoint)
    named = [(f, v) for (f, _, _), v in zip(fields, values) if f != "_"]
    assert sorted(pcd.fields) == sorted(f for f, _ in named)
    for f, v in named:
        assert pcd.fields[f].dtype == v.dtype
        np.testing.assert_array_equal(pcd.fields[f], v)
    scan = refused_or(lambda: validate_scan(read_labelled_scan(p), 4))
    if n == 0:
        assert scan is None  # an empty cloud is refused, never returned
    else:
        np.testing.assert_array_equal(scan.points[:, 0], values[[f for f, _, _ in fields].index("x")])
        np.testing.assert_array_equal(scan.labels, values[[f for f, _, _ in fields].index("label")])


def _header_of(raw: bytes) -> tuple[dict, int] | None:
    """An independent parse of a PCD header: {KEY: [values]} and the data offset."""
    pos, header = 0, {}
    while True:
        end = raw.find(b"\n", pos)
        if end < 0:
            return None
        line = raw[pos:end].decode("ascii", "replace").strip()
        pos = end + 1
        if line and not line.startswith("#"):
            key, *vals = line.split()
            header[key.upper()] = vals
            if key.upper() == "DATA":
                return header, pos


@st.composite
def mutated(draw):
    raw = bytearray(encode(*draw(clouds())))
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["flip", "insert", "delete", "dup_line", "drop_line", "token",
                                   "truncate", "append"]))
        lines = bytes(raw).split(b"\n")
        if op == "flip" and raw:
            i = draw(st.integers(0, len(raw) - 1))
            raw[i] = draw(st.integers(0, 255))
        elif op == "insert":
            i = draw(st.integers(0, len(raw)))
            raw[i:i] = draw(st.binary(min_size=1, max_size=8))
        elif op == "delete" and raw:
            i = draw(st.integers(0, len(raw) - 1))
            del raw[i:i + draw(st.integers(1, 16))]
        elif op in ("dup_line", "drop_line") and len(lines) > 1:
            i = draw(st.integers(0, len(lines) - 2))
            if op == "dup_line":
                lines.insert(i, lines[i])
            else:
                del lines[i]
            raw = bytearray(b"\n".join(lines))
        elif op == "token":
            i = draw(st.integers(0, min(len(lines), 12) - 1))
            words = lines[i].split(b" ")
            j = draw(st.integers(0, len(words) - 1))
            words[j] = draw(st.sampled_from(NASTY)).encode()
            lines[i] = b" ".join(words)
            raw = bytearray(b"\n".join(lines))
        elif op == "truncate":
            del raw[draw(st.integers(0, len(raw))):]
        elif op == "append":
            raw += draw(st.sampled_from([b"\n", b"1 2 3 4\n", b"\x00" * 16, b"nan nan nan 1\n"]))
    return bytes(raw)


@settings(max_examples=examples(300))
@given(mutated())
def test_mutated_pcd_is_read_as_its_header_says_or_refused(raw):
    p = write(raw)
    pcd = refused_or(lambda: read_pcd(p))
    if pcd is not None:
        parsed = _header_of(raw)
        assert parsed is not None
        header, start = parsed
        n = int(header["POINTS"][0])
        names = header["FIELDS"]
        assert len(set(f for f in names if f != "_")) == len([f for f in names if f != "_"])
        assert sorted(pcd.fields) == sorted(set(names) - {"_"})
        counts = [int(c) for c in header.get("COUNT", ["1"] * len(names))]
        for f, c in zip(names, counts):
            if f != "_":
                assert pcd.fields[f].shape == ((n,) if c == 1 else (n, c))
        body = raw[start:]
        if pcd.data == "ascii":
            assert len([ln for ln in body.splitlines() if ln.strip()]) == n
        else:
            size = sum(int(s) * c for s, c in zip(header["SIZE"], counts))
            assert len(body.rstrip(b"\r\n")) <= n * size <= len(body)
        assert np.all(np.isfinite(pcd.viewpoint))
    scan = refused_or(lambda: validate_scan(read_labelled_scan(p), 4))
    if scan is not None:
        assert np.all(np.isfinite(scan.points)) and np.all(np.isfinite(scan.origin))
        assert scan.labels.dtype == np.int64 and scan.labels.min() >= 1 and scan.labels.max() <= 3
