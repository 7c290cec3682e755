"""Every bad input gets a clear exception naming the argument: never a crash, never a wrong answer."""

from __future__ import annotations

import struct
import tempfile
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from conftest import sphere
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import kdray

V, F = sphere(6, 8)
TREE = kdray.TriangleTree(V, F)
PTS = np.random.default_rng(0).random((300, 3))
KD = kdray.KDTree(PTS)


def _short_glb() -> str:
    """A GLB whose header's length is shorter than the header itself."""
    with tempfile.NamedTemporaryFile(suffix=".glb", delete=False) as f:
        f.write(b"glTF" + struct.pack("<II", 2, 4) + bytes(20))
    return f.name


BAD: list[tuple[str, Callable[[], Any], type[BaseException], str]] = [
    ("vertices 2-D (V, 2)", lambda: kdray.TriangleTree(V[:, :2], F), ValueError, "vertices"),
    ("vertices 1-D", lambda: kdray.TriangleTree(V.ravel(), F), ValueError, "vertices"),
    ("vertices NaN", lambda: kdray.TriangleTree(np.where(np.arange(len(V))[:, None] == 3, np.nan, V), F), ValueError, "vertices.*row 3"),
    ("vertices inf in float32", lambda: kdray.TriangleTree(V * 1e300, F), ValueError, "vertices"),
    ("vertices beyond MAX_COORD", lambda: kdray.TriangleTree(V * 1e30, F), ValueError, "range"),
    ("vertices strings", lambda: kdray.TriangleTree(V.astype(str), F), ValueError, "vertices"),
    ("vertices ragged", lambda: kdray.TriangleTree([[0, 0, 0], [1, 1]], F), ValueError, "vertices"),
    ("triangles float", lambda: kdray.TriangleTree(V, F.astype(float)), ValueError, "triangles"),
    ("triangles (F, 4)", lambda: kdray.TriangleTree(V, np.hstack([F, F[:, :1]])), ValueError, "triangles"),
    ("triangles index too large", lambda: kdray.TriangleTree(V, np.where(F == F.max(), len(V), F)), ValueError, "triangles.*outside"),
    ("triangles index negative", lambda: kdray.TriangleTree(V, -F), ValueError, "triangles.*outside"),
    ("triangles empty", lambda: kdray.TriangleTree(V, np.zeros((0, 3), int)), ValueError, "triangles"),
    ("builder unknown", lambda: kdray.TriangleTree(V, F, builder="bvh"), ValueError, "builder"),
    ("traversal_cost 0", lambda: kdray.TriangleTree(V, F, traversal_cost=0), ValueError, "traversal_cost"),
    ("empty_bonus 1", lambda: kdray.TriangleTree(V, F, empty_bonus=1.0), ValueError, "empty_bonus"),
    ("max_depth past the stack", lambda: kdray.TriangleTree(V, F, max_depth=65), ValueError, "max_depth 65 is more than 64"),
    ("threads huge", lambda: kdray.TriangleTree(V, F, threads=10**6), ValueError, "threads 1000000 is more than 1024"),
    ("blob empty is truncated", lambda: kdray.TriangleTree.from_bytes(b""), kdray.BlobError, "truncated in the header.*has 0"),
    ("GLB cut short", lambda: kdray.TriangleTree.from_file(_short_glb()), ValueError, "GLB header's length"),
    ("mesh file missing", lambda: kdray.TriangleTree.from_file("/nonexistent.obj"), ValueError, "nonexistent"),
    ("rays (N, 5)", lambda: TREE.cast_rays(np.zeros((3, 5))), ValueError, "rays"),
    ("rays complex", lambda: TREE.cast_rays(np.zeros((3, 6), complex)), ValueError, "rays"),
    ("rays and origins", lambda: TREE.cast_rays(np.zeros((3, 6)), origins=np.zeros((3, 3)), directions=np.zeros((3, 3))), ValueError, "either"),
    ("origins without directions", lambda: TREE.cast_rays(origins=np.zeros((3, 3))), ValueError, "directions"),
    ("origins/directions shapes", lambda: TREE.cast_rays(origins=np.zeros((3, 3)), directions=np.zeros((4, 3))), ValueError, "differ"),
    ("tfar shape", lambda: TREE.test_occlusions(np.zeros((3, 6)), tfar=np.ones(4)), ValueError, "tfar"),
    ("nthreads negative", lambda: TREE.cast_rays(np.zeros((3, 6)), nthreads=-2), ValueError, "nthreads"),
    ("nthreads huge", lambda: TREE.cast_rays(np.zeros((3000, 6)), nthreads=10**6), ValueError, "nthreads"),
    ("nthreads past 64 bits", lambda: TREE.cast_rays(np.zeros((3, 6)), nthreads=2**70), ValueError, "nthreads 1180591620717411303424 is more than"),
    ("nthreads float", lambda: TREE.compute_distance(np.zeros((3, 3)), nthreads=1.5), TypeError, "nthreads must be an integer, not 1.5"),
    ("workers past 64 bits", lambda: KD.query(PTS[:2], workers=2**64), ValueError, "workers 18446744073709551616 is more than"),
    ("packet 3", lambda: TREE.cast_rays(np.zeros((3, 6)), packet=3), ValueError, "packet"),
    ("blob empty", lambda: kdray.TriangleTree.from_bytes(b""), kdray.BlobError, "buffer"),
    ("blob truncated", lambda: kdray.TriangleTree.from_bytes(TREE.to_bytes()[:-4]), kdray.BlobError, "buffer"),
    ("blob of points", lambda: kdray.TriangleTree.from_bytes(KD.to_bytes()), kdray.BlobError, "buffer"),
    ("blob not bytes", lambda: kdray.TriangleTree.from_bytes(np.zeros(10, np.float32)), TypeError, "buffer"),
    ("blob str", lambda: kdray.TriangleTree.from_bytes("abc"), TypeError, "buffer"),
    ("scene from tree blob", lambda: kdray.Scene.from_bytes(TREE.to_bytes()), kdray.BlobError, "scene"),
    ("scene constructor", lambda: kdray.Scene(), TypeError, "Scene.load"),
    ("load missing", lambda: kdray.TriangleTree.load("/nonexistent.kdt"), OSError, "nonexistent"),
    ("data 1-D", lambda: kdray.KDTree(np.zeros(5)), ValueError, "data"),
    ("data empty", lambda: kdray.KDTree(np.zeros((0, 3))), ValueError, "data"),
    ("data 17-D", lambda: kdray.KDTree(np.zeros((5, 17))), NotImplementedError, "17"),
    ("data NaN", lambda: kdray.KDTree(np.where(np.arange(300)[:, None] == 7, np.nan, PTS)), ValueError, "data.*row 7"),
    ("data boxsize", lambda: kdray.KDTree(PTS, boxsize=1.0), NotImplementedError, "boxsize"),
    ("leafsize 0", lambda: kdray.KDTree(PTS, leafsize=0), ValueError, "leafsize"),
    ("x wrong width", lambda: KD.query(np.zeros((3, 2))), ValueError, "x"),
    ("x strings", lambda: KD.query(np.array([["a", "b", "c"]])), ValueError, "x"),
    ("k 0", lambda: KD.query(PTS[:2], k=0), ValueError, "k"),
    ("k ranks from 0", lambda: KD.query(PTS[:2], k=[0, 1]), ValueError, "k"),
    ("k huge", lambda: KD.query(PTS[:2000], k=10**12), ValueError, "k"),
    ("k past memory", lambda: KD.query(PTS[0], k=10**12), ValueError, "k=1000000000000.*does not fit in memory"),
    ("k float", lambda: KD.query(PTS[:2], k=[1.5]), ValueError, "k"),
    ("p 1", lambda: KD.query(PTS[:2], p=1), NotImplementedError, "p=1"),
    ("p inf", lambda: KD.query_ball_point(PTS[:2], 0.1, p=np.inf), NotImplementedError, "p=inf"),
    ("eps negative", lambda: KD.query(PTS[:2], eps=-1), ValueError, "eps"),
    ("upper bound NaN", lambda: KD.query(PTS[:2], distance_upper_bound=np.nan), ValueError, "distance_upper_bound"),
    ("workers 0", lambda: KD.query(PTS[:2], workers=0), ValueError, "workers"),
    ("r NaN", lambda: KD.query_ball_point(PTS[:2], np.nan), ValueError, "r"),
    ("r shape", lambda: KD.query_ball_point(PTS[:2], [0.1, 0.2, 0.3]), ValueError, "r"),
    ("point blob truncated", lambda: kdray.KDTree.from_bytes(KD.to_bytes()[:100]), kdray.BlobError, "buffer"),
    ("point blob of triangles", lambda: kdray.KDTree.from_bytes(TREE.to_bytes()), kdray.BlobError, "buffer"),
]


@pytest.mark.parametrize("case", BAD, ids=[c[0] for c in BAD])
def test_bad_input_is_refused(case: tuple[str, Callable[[], Any], type[BaseException], str]) -> None:
    _, call, exc, match = case
    with pytest.raises(exc, match=match):
        call()


def test_inputs_are_read_not_written_and_any_layout_works() -> None:
    rays = np.random.default_rng(1).normal(size=(100, 12)).astype(np.float64)
    view = rays[:, ::2]  # non-contiguous, float64
    view.flags.writeable = False
    before = rays.copy()
    got = TREE.cast_rays(view)
    np.testing.assert_array_equal(rays, before)
    want = TREE.cast_rays(np.ascontiguousarray(view, np.float32))
    for k in got:
        np.testing.assert_array_equal(got[k], want[k])
    x = np.asfortranarray(PTS[:50])
    x.flags.writeable = False
    for a, b in zip(KD.query(x, k=2), KD.query(np.ascontiguousarray(PTS[:50]), k=2)):
        np.testing.assert_array_equal(a, b)
    v = np.asfortranarray(V)
    v.flags.writeable = False
    f = F[:, ::-1][:, ::-1]
    assert kdray.TriangleTree(v, f).to_bytes() == kdray.TriangleTree(V, F).to_bytes()


@settings(max_examples=60, deadline=None)
@given(st.binary(max_size=4096), st.integers(0, 4095), st.integers(0, 255))
def test_damaged_blobs_are_refused(junk: bytes, at: int, flip: int) -> None:
    for good, cls in ((TREE.to_bytes(), kdray.TriangleTree), (KD.to_bytes(), kdray.KDTree)):
        for blob in (junk, good[: at % len(good)], bytes(good[:at % len(good)]) + bytes([good[at % len(good)] ^ (flip | 1)]) + good[at % len(good) + 1 :]):
            try:
                cls.from_bytes(blob)
            except kdray.BlobError:
                continue
            # Only an unchanged blob loads.
            assert blob == good


@settings(max_examples=40, deadline=None)
@given(hnp.arrays(np.float32, st.tuples(st.integers(0, 20), st.just(6)), elements=st.floats(width=32)))
def test_any_rays_answer_as_brute_force(rays: np.ndarray) -> None:
    layout = np.zeros((len(rays), 8), np.float32)
    layout[:, 0:3], layout[:, 4:7], layout[:, 7] = rays[:, :3], rays[:, 3:], np.inf
    got = TREE.cast_rays(rays)
    want = TREE._tree.cast_brute(layout)
    np.testing.assert_array_equal(got["t_hit"].view(np.uint32), want[0].view(np.uint32))
    np.testing.assert_array_equal(got["primitive_ids"], want[1])
    np.testing.assert_array_equal(TREE.test_occlusions(rays), TREE._tree.occluded_brute(layout))


@settings(max_examples=40, deadline=None)
@given(
    hnp.arrays(np.float64, st.tuples(st.integers(1, 40), st.just(2)), elements=st.floats(-1e6, 1e6)),
    hnp.arrays(np.float64, st.tuples(st.integers(0, 10), st.just(2)), elements=st.floats(-1e6, 1e6)),
    st.integers(1, 50),
)
def test_any_points_answer_as_brute_force(data: np.ndarray, x: np.ndarray, k: int) -> None:
    d, i = kdray.KDTree(data).query(x, k=k)
    diff = x[:, None, :] - data[None]
    d2 = diff[..., 0] * diff[..., 0] + diff[..., 1] * diff[..., 1]
    order = np.argsort(d2, axis=1, kind="stable")[:, :k]
    kk = min(k, len(data))
    if k == 1:
        d, i = d[:, None], i[:, None]
    np.testing.assert_array_equal(i[:, :kk], order)
    np.testing.assert_array_equal(d[:, :kk], np.sqrt(np.take_along_axis(d2, order, 1)))
    assert np.all(i[:, kk:] == len(data)) and np.all(np.isinf(d[:, kk:]))
