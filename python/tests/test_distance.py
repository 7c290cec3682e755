"""Distance queries: closest points, distances, signs and occupancy, exact.

The oracle is Ericson's closest-point test written again here in numpy
``float64`` with the kernel's operation order (docs/distance.md), over
every triangle, smallest squared distance then lowest index: the tree's
answers must equal it bit for bit. The signs are checked against convex
meshes, where inside is known from the face planes.
"""

from __future__ import annotations

import pickle
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from conftest import kdray_cli, soup, sphere

import kdray


def bits(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    return a.view(np.uint64 if a.dtype.itemsize == 8 else np.uint32)


# --- the numpy oracle ----------------------------------------------------


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _ratio(n: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``n / d`` clamped to [0, 1]; 0 when ``d`` is not positive or the ratio NaN."""
    s = n / d
    return np.where((d > 0) & (s > 0), np.minimum(s, 1.0), 0.0)


def _at(a: np.ndarray, ab: np.ndarray, ac: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return a + u[:, None] * ab + v[:, None] * ac


def on_triangles(q: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every triangle's closest point to ``q`` (float64): ``(p (F, 3), u, v, d2)``."""
    a, b, c = (tris[:, i].astype(np.float64) for i in range(3))
    ab, ac, bc = b - a, c - a, c - b
    d1, d2 = _dot(ab, q - a), _dot(ac, q - a)
    d3, d4 = _dot(ab, q - b), _dot(ac, q - b)
    d5, d6 = _dot(ab, q - c), _dot(ac, q - c)
    vc, vb, va = d1 * d4 - d3 * d2, d5 * d2 - d1 * d6, d3 * d6 - d5 * d4
    zero, one = np.zeros(len(tris)), np.ones(len(tris))
    total = va + vb + vc
    fu, fv = vb / total, vc / total
    s_ab = _ratio(d1, d1 - d3)
    s_ac = _ratio(d2, d2 - d6)
    s_bc = _ratio(d4 - d3, (d4 - d3) + (d5 - d6))
    # Ericson's regions in the kernel's order: the first that holds wins.
    regions = [
        ((d1 <= 0) & (d2 <= 0), a, zero, zero),
        ((d3 >= 0) & (d4 <= d3), b, one, zero),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), _at(a, ab, ac, s_ab, zero), s_ab, zero),
        ((d6 >= 0) & (d5 <= d6), c, zero, one),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), _at(a, ab, ac, zero, s_ac), zero, s_ac),
        ((va <= 0) & (d4 >= d3) & (d5 >= d6), b + s_bc[:, None] * bc, 1.0 - s_bc, s_bc),
        (
            (va >= 0) & (vb >= 0) & (vc >= 0) & (total > 0) & np.isfinite(total),
            _at(a, ab, ac, fu, fv),
            fu,
            fv,
        ),
    ]
    # A degenerate triangle the rounding sent to the face: its nearest edge, the first of equals.
    best_p, best_u, best_v, best_d2 = a, zero, zero, np.full(len(tris), np.inf)
    for p0, e, which in ((a, ab, 0), (a, ac, 1), (b, bc, 2)):
        s = _ratio(_dot(q - p0, e), _dot(e, e))
        p = p0 + s[:, None] * e
        u, v = ((s, zero), (zero, s), (1.0 - s, s))[which]
        d2e = _dot(q - p, q - p)
        take = (d2e < best_d2) | (which == 0)
        best_p = np.where(take[:, None], p, best_p)
        best_u, best_v = np.where(take, u, best_u), np.where(take, v, best_v)
        best_d2 = np.where(take, d2e, best_d2)
    p, u, v = best_p, best_u, best_v
    for mask, rp, ru, rv in reversed(regions):
        p = np.where(mask[:, None], rp, p)
        u, v = np.where(mask, ru, u), np.where(mask, rv, v)
    d = q - p
    return p, u, v, _dot(d, d)


def oracle(tris: np.ndarray, queries: np.ndarray) -> dict[str, np.ndarray]:
    """The closest point of every query over every triangle, as the kernel rounds it."""
    n = len(queries)
    out = {
        "points": np.full((n, 3), np.nan, np.float32),
        "primitive_ids": np.full(n, kdray.MISS, np.uint32),
        "primitive_uvs": np.full((n, 2), np.nan, np.float32),
        "distance2": np.full(n, np.nan),
    }
    for j, q in enumerate(queries.astype(np.float64)):
        if not np.isfinite(q).all():
            continue
        with np.errstate(all="ignore"):  # the regions not taken may overflow or divide by 0
            p, u, v, d2 = on_triangles(q, tris)
        i = int(np.argmin(d2))  # the first of equals: the lowest index
        out["points"][j] = p[i].astype(np.float32)
        out["primitive_ids"][j] = i
        out["primitive_uvs"][j] = np.array([u[i], v[i]]).astype(np.float32)
        out["distance2"][j] = d2[i]
    return out


def unit_normals(tris: np.ndarray) -> np.ndarray:
    """``cast_rays``' normals: ``(v1 - v0) x (v2 - v0)`` over its length, in float32 as the
    kernel computes them (zero for a degenerate triangle)."""
    e1, e2 = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    n = np.stack(
        [
            e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1],
            e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2],
            e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0],
        ],
        axis=1,
    )
    length = np.sqrt(n[:, 0] * n[:, 0] + n[:, 1] * n[:, 1] + n[:, 2] * n[:, 2])
    ok = (length > 0) & np.isfinite(length)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ok[:, None], n / length[:, None], np.float32(0))


def queries_for(tree: kdray.TriangleTree, n: int, seed: int) -> np.ndarray:
    """Points in the tree's box dilated by 20%, and some on its vertices and edges."""
    rng = np.random.default_rng(seed)
    lo, hi = tree.bounds
    pad = (hi - lo) * 0.2
    box = (lo - pad) + (hi - lo + 2 * pad) * rng.random((n, 3))
    tris = tree.triangles
    pick = rng.integers(0, len(tris), n // 4)
    on_vertex = tris[pick, rng.integers(0, 3, len(pick))]
    w = rng.random((len(pick), 1))
    on_edge = (w * tris[pick, 0] + (1 - w) * tris[pick, 1]).astype(np.float32)
    return np.vstack([box.astype(np.float32), on_vertex, on_edge])


def assert_closest_equal(got: dict[str, np.ndarray], want: dict[str, np.ndarray]) -> None:
    for name in ("points", "primitive_ids", "primitive_uvs"):
        np.testing.assert_array_equal(bits(got[name]), bits(want[name]), err_msg=name)


MESHES = {
    "sphere": lambda: sphere(12, 16),
    "soup": lambda: soup(400, 3),
    # A soup with degenerate triangles: segments and points.
    "degenerate": lambda: degenerate_soup(),
}


def degenerate_soup() -> tuple[np.ndarray, np.ndarray]:
    v, f = soup(200, 5)
    t = v[f].copy()
    t[::3, 2] = t[::3, 1]  # a repeated vertex
    t[1::3, 2] = 0.5 * (t[1::3, 0] + t[1::3, 1])  # collinear
    t[2::9, 1:] = t[2::9, :1]  # a point
    return t.reshape(-1, 3), np.arange(3 * len(t)).reshape(-1, 3)


@pytest.fixture(scope="module", params=sorted(MESHES))
def tree(request: pytest.FixtureRequest) -> kdray.TriangleTree:
    return kdray.TriangleTree(*MESHES[request.param]())


def test_closest_points_equal_the_numpy_oracle(tree: kdray.TriangleTree) -> None:
    q = queries_for(tree, 400, 1)
    got = tree.compute_closest_points(q)
    want = oracle(tree.triangles, q)
    assert_closest_equal(got, want)
    d = tree.compute_distance(q)
    np.testing.assert_array_equal(bits(d), bits(np.sqrt(want["distance2"]).astype(np.float32)))
    want_n = unit_normals(tree.triangles)[got["primitive_ids"]]
    np.testing.assert_array_equal(bits(got["primitive_normals"]), bits(want_n))


def test_closest_points_equal_the_kernels_brute_force(tree: kdray.TriangleTree) -> None:
    q = queries_for(tree, 4000, 2)  # many rayon tasks of 256 queries, on two threads
    got = tree.compute_closest_points(q, nthreads=2)
    points, ids, uvs, d2 = tree._tree.closest_points_brute(q)
    assert_closest_equal(got, {"points": points, "primitive_ids": ids, "primitive_uvs": uvs})
    np.testing.assert_array_equal(bits(tree.compute_distance(q)), bits(np.sqrt(d2).astype(np.float32)))


def test_normals_are_cast_rays_normals() -> None:
    v, f = sphere(12, 16)
    tree = kdray.TriangleTree(v, f)
    q = queries_for(tree, 500, 3) * np.float32(1.5)
    cp = tree.compute_closest_points(q)
    # A ray from the query to its closest point hits that triangle there.
    rays = np.hstack([q, cp["points"] - q]).astype(np.float32)
    hits = tree.cast_rays(rays)
    same = hits["primitive_ids"] == cp["primitive_ids"]
    assert same.sum() > 200
    np.testing.assert_array_equal(
        bits(hits["primitive_normals"][same]), bits(cp["primitive_normals"][same])
    )


def test_shapes_and_dtypes_are_open3ds(tree: kdray.TriangleTree) -> None:
    q = queries_for(tree, 24, 4)[:24].reshape(2, 3, 4, 3)
    cp = tree.compute_closest_points(q)
    assert set(cp) == {"points", "primitive_ids", "primitive_uvs", "primitive_normals"}
    assert cp["points"].shape == (2, 3, 4, 3) and cp["points"].dtype == np.float32
    assert cp["primitive_ids"].shape == (2, 3, 4) and cp["primitive_ids"].dtype == np.uint32
    assert cp["primitive_uvs"].shape == (2, 3, 4, 2) and cp["primitive_uvs"].dtype == np.float32
    assert cp["primitive_normals"].shape == (2, 3, 4, 3)
    for call in (tree.compute_distance, tree.compute_signed_distance, tree.compute_occupancy):
        out = call(q)
        assert out.shape == (2, 3, 4) and out.dtype == np.float32, call
    flat = tree.compute_closest_points(q.reshape(-1, 3))
    for k in cp:
        np.testing.assert_array_equal(cp[k].reshape(flat[k].shape), flat[k])
    one = tree.compute_distance(q[0, 0, 0])
    assert one.shape == () and one == tree.compute_distance(q)[0, 0, 0]
    empty = tree.compute_closest_points(np.zeros((0, 3)))
    assert empty["points"].shape == (0, 3) and empty["primitive_ids"].shape == (0,)
    assert tree.compute_occupancy(np.zeros((5, 0, 3))).shape == (5, 0)
    # Any float dtype, any layout: converted once to float32.
    q64 = np.asfortranarray(q.reshape(-1, 3).astype(np.float64))
    np.testing.assert_array_equal(tree.compute_distance(q64), tree.compute_distance(q.reshape(-1, 3)))
    np.testing.assert_array_equal(
        tree.compute_distance(q.astype(np.float16)),
        tree.compute_distance(q.astype(np.float16).astype(np.float32)),
    )


def test_non_finite_queries_have_defined_answers(tree: kdray.TriangleTree) -> None:
    q = np.array([[np.nan, 0, 0], [0, np.inf, 0], [0, 0, -np.inf], [1e39, 0, 0], [0.5, 0.5, 0.5]])
    cp = tree.compute_closest_points(q)
    bad = slice(0, 4)
    assert np.all(np.isnan(cp["points"][bad])) and np.all(np.isnan(cp["primitive_uvs"][bad]))
    assert np.all(cp["primitive_ids"][bad] == kdray.MISS)
    assert np.all(cp["primitive_normals"][bad] == 0)
    assert cp["primitive_ids"][4] != kdray.MISS
    assert np.all(np.isnan(tree.compute_distance(q)[bad]))
    assert np.all(np.isnan(tree.compute_signed_distance(q)[bad]))
    assert np.all(tree.compute_occupancy(q)[bad] == 0)


# --- signs on closed meshes ----------------------------------------------


def cube() -> tuple[np.ndarray, np.ndarray]:
    """The cube [-1, 1]^3, 12 triangles wound outwards."""
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    f = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return v, np.array(f)


def convex_inside(tris: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For a convex mesh's triangles: (strictly inside, strictly outside) by the face planes."""
    t = tris.astype(np.float64)
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    centre = t.reshape(-1, 3).mean(axis=0)
    n *= -np.sign(np.einsum("fk,fk->f", n, centre - t[:, 0]))[:, None]  # outwards, whatever the winding
    side = np.einsum("fk,qfk->qf", n, q[:, None, :].astype(np.float64) - t[None, :, 0])
    return (side < 0).all(axis=1), (side > 0).any(axis=1)


def near_surface(v: np.ndarray, f: np.ndarray, seed: int) -> np.ndarray:
    """Points just off the vertices, the edge midpoints and the face centres, both sides."""
    rng = np.random.default_rng(seed)
    t = v[f].astype(np.float64)
    spots = np.vstack([t.reshape(-1, 3), (t[:, 0] + t[:, 1]) / 2, (t[:, 1] + t[:, 2]) / 2, t.mean(axis=1)])
    pts = []
    for scale in (1 - 2e-3, 1 - 1e-5, 1 + 1e-5, 1 + 2e-3):
        pts.append(spots * scale)
    jitter = rng.normal(size=(len(spots), 3)) * 1e-3
    pts.append(spots + jitter)
    return np.vstack(pts).astype(np.float32)


@pytest.mark.parametrize("shape", ["cube", "sphere"])
@pytest.mark.parametrize("nsamples", [1, 3, 5, 7])
def test_signs_on_closed_convex_meshes(shape: str, nsamples: int) -> None:
    v, f = cube() if shape == "cube" else sphere(10, 14)
    tree = kdray.TriangleTree(v, f)
    rng = np.random.default_rng(5)
    q = np.vstack([near_surface(v, f, 6), (rng.random((3000, 3)) * 3 - 1.5).astype(np.float32)])
    inside, outside = convex_inside(tree.triangles, q)
    assert inside.sum() > 500 and outside.sum() > 500
    occ = tree.compute_occupancy(q, nsamples=nsamples)
    assert set(np.unique(occ)) <= {0.0, 1.0}
    np.testing.assert_array_equal(occ[inside], 1)
    np.testing.assert_array_equal(occ[outside], 0)
    d = tree.compute_distance(q)
    sd = tree.compute_signed_distance(q, nsamples=nsamples)
    np.testing.assert_array_equal(bits(sd), bits(np.where(occ == 1, -d, d)))


def test_votes_on_an_open_mesh() -> None:
    v, f = sphere(10, 14)
    holed = np.delete(f, np.arange(0, len(f), 9), axis=0)  # every ninth triangle gone
    tree = kdray.TriangleTree(v, holed)
    rng = np.random.default_rng(7)
    q = rng.normal(size=(2000, 3))
    q *= 0.8 * rng.random((2000, 1)) ** (1 / 3) / np.linalg.norm(q, axis=1, keepdims=True)
    q = q.astype(np.float32)
    inside, _ = convex_inside(kdray.TriangleTree(v, f).triangles, q)
    assert inside.all()
    errors = {n: int((tree.compute_occupancy(q, nsamples=n) != 1).sum()) for n in (1, 3, 5, 7)}
    # One ray through a hole misjudges a point; the majority of seven rarely does.
    assert errors[1] > 0
    assert errors[7] < errors[1]
    # The winding number with the holes capped misjudges none, inside or out.
    assert (tree.compute_occupancy(q, winding=True) == 1).all()
    far = (rng.random((500, 3)) * 2 + 1.2).astype(np.float32)
    assert (tree.compute_occupancy(far, winding=True) == 0).all()
    d = tree.compute_distance(q)
    np.testing.assert_array_equal(bits(tree.compute_signed_distance(q, winding=True)), bits(-d))


# --- against other tools -------------------------------------------------


def test_equals_the_cli(tmp_path: Path) -> None:
    cli = kdray_cli()
    if cli is None:
        pytest.skip("no kdray binary (cargo build --release, or set KDRAY_BIN)")
    v, f = sphere(16, 24)
    tree = kdray.TriangleTree(v, f)
    blob, pts, out = tmp_path / "s.kdt", tmp_path / "q.pts", tmp_path / "q.dist"
    tree.save(blob)
    q = queries_for(tree, 3000, 8)
    q.tofile(pts)
    cases: tuple[tuple[list[str], int | None, bool], ...] = (
        ([], None, False),
        (["--signed"], 1, False),
        (["--signed", "--votes", "5"], 5, False),
        (["--signed", "--winding"], 1, True),
    )
    for extra, nsamples, winding in cases:
        subprocess.run([cli, "distance", blob, pts, "-o", out, *extra], check=True, capture_output=True)
        rec = np.fromfile(out, dtype=np.float32).reshape(-1, 7)
        cp = tree.compute_closest_points(q)
        np.testing.assert_array_equal(bits(cp["points"]), bits(rec[:, 0:3]))
        np.testing.assert_array_equal(cp["primitive_ids"], bits(rec[:, 3]))
        np.testing.assert_array_equal(bits(cp["primitive_uvs"]), bits(rec[:, 4:6]))
        d = (
            tree.compute_distance(q)
            if nsamples is None
            else tree.compute_signed_distance(q, nsamples=nsamples, winding=winding)
        )
        np.testing.assert_array_equal(bits(d), bits(rec[:, 6]))


def test_distances_agree_with_trimesh() -> None:
    trimesh = pytest.importorskip("trimesh")
    pytest.importorskip("rtree")  # trimesh's closest_point needs it
    v, f = sphere(16, 24)
    tree = kdray.TriangleTree(v, f)
    mesh = trimesh.Trimesh(tree.triangles.reshape(-1, 3).astype(np.float64), np.arange(3 * len(f)).reshape(-1, 3), process=False)
    q = queries_for(tree, 2000, 9).astype(np.float64)
    points, dist, ids = trimesh.proximity.closest_point(mesh, q)
    np.testing.assert_allclose(tree.compute_distance(q), dist, rtol=1e-6, atol=1e-6)
    cp = tree.compute_closest_points(q)
    # Points on shared edges and vertices tie: another triangle as near, the same point.
    same = cp["primitive_ids"] == ids
    assert same.mean() > 0.5
    np.testing.assert_allclose(cp["points"][same], points[same], atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(cp["points"] - q, axis=1), dist, atol=1e-6)


# --- threads, pickling, bad input ------------------------------------------


def test_threads_at_once_and_pickled_trees_answer_alike() -> None:
    v, f = sphere()
    tree = kdray.TriangleTree(v, f)
    q = queries_for(tree, 20_000, 10)
    want = (tree.compute_closest_points(q), tree.compute_signed_distance(q, nsamples=3))
    again = pickle.loads(pickle.dumps(tree, protocol=5))
    assert_closest_equal(again.compute_closest_points(q), want[0])
    np.testing.assert_array_equal(bits(again.compute_signed_distance(q, nsamples=3)), bits(want[1]))

    def work(j: int) -> None:
        t = again if j % 2 else tree
        assert_closest_equal(t.compute_closest_points(q, nthreads=j % 3), want[0])
        got = t.compute_signed_distance(q, nthreads=j % 3, nsamples=3)
        np.testing.assert_array_equal(bits(got), bits(want[1]))

    with ThreadPoolExecutor(6) as ex:
        for fut in [ex.submit(work, j) for j in range(12)]:
            fut.result()


TREE = kdray.TriangleTree(*sphere(6, 8))
Q = np.zeros((4, 3))

BAD = [
    ("query_points (N, 2)", lambda: TREE.compute_distance(np.zeros((3, 2))), "query_points"),
    ("query_points 0-D", lambda: TREE.compute_closest_points(np.float32(1)), "query_points"),
    ("query_points strings", lambda: TREE.compute_signed_distance(np.array([["a", "b", "c"]])), "query_points"),
    ("query_points ragged", lambda: TREE.compute_occupancy([[0, 0, 0], [1, 1]]), "query_points"),
    ("query_points complex", lambda: TREE.compute_distance(np.zeros((2, 3), complex)), "query_points"),
    ("nthreads negative", lambda: TREE.compute_distance(Q, nthreads=-1), "nthreads"),
    ("nthreads huge", lambda: TREE.compute_closest_points(Q, nthreads=10**6), "nthreads"),
    ("nsamples 0", lambda: TREE.compute_occupancy(Q, nsamples=0), "nsamples"),
    ("nsamples even", lambda: TREE.compute_signed_distance(Q, nsamples=2), "nsamples"),
    ("nsamples 9", lambda: TREE.compute_occupancy(Q, nsamples=9), "nsamples"),
    ("nsamples negative", lambda: TREE.compute_occupancy(Q, nsamples=-1), "nsamples"),
    ("nsamples huge", lambda: TREE.compute_signed_distance(Q, nsamples=2**70 + 1), "nsamples"),
    ("nsamples float", lambda: TREE.compute_occupancy(Q, nsamples=3.0), "nsamples"),  # type: ignore[arg-type]
    ("nsamples bool", lambda: TREE.compute_occupancy(Q, nsamples=True), "nsamples"),
    ("winding with rays", lambda: TREE.compute_signed_distance(Q, nsamples=3, winding=True), "winding"),
]


@pytest.mark.parametrize("case", BAD, ids=[c[0] for c in BAD])
def test_bad_input_is_refused(case: tuple[str, object, str]) -> None:
    _, call, match = case
    with pytest.raises(ValueError, match=match):
        call()  # type: ignore[operator]


def test_compiled_layer_refuses_what_the_python_layer_would() -> None:
    with pytest.raises(ValueError, match="nsamples"):
        TREE._tree.occupancy(np.zeros((2, 3), np.float32), 0, 4, False)
    with pytest.raises(ValueError, match="winding"):
        TREE._tree.signed_distances(np.zeros((2, 3), np.float32), 0, 3, True)
    with pytest.raises(ValueError, match="query_points"):
        TREE._tree.distances(np.zeros((2, 4), np.float32), 0)
    with pytest.raises(ValueError, match="query_points.*C-contiguous"):
        TREE._tree.closest_points(np.zeros((3, 6), np.float32)[:, ::2], 0)
