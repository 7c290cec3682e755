"""KDTree: scipy's answers (up to distance ties) and brute force's bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import kdray


def point_sets(n: int, m: int, dtype: type, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    uniform = rng.random((n, m))
    centres = rng.random((8, m))
    clustered = centres[rng.integers(0, 8, n)] + rng.normal(scale=0.01, size=(n, m))
    dup = rng.integers(0, 5, (n, m)).astype(np.float64)  # few distinct points
    return {k: v.astype(dtype) for k, v in {"uniform": uniform, "clustered": clustered, "dup": dup}.items()}


def brute(data: np.ndarray, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's arithmetic in numpy: squared distance summed left to right in the dtype."""
    diff = x[:, None, :] - data[None, :, :]
    d2 = diff[..., 0] * diff[..., 0]
    for a in range(1, data.shape[1]):
        d2 = d2 + diff[..., a] * diff[..., a]
    order = np.argsort(d2, axis=1, kind="stable")[:, :k]  # ties: the lower index
    return np.sqrt(np.take_along_axis(d2, order, 1)), order


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("m", [1, 2, 3, 5, 8, 16])
def test_query_equals_brute_force_and_scipy(m: int, dtype: type) -> None:
    for name, data in point_sets(1500, m, dtype, m).items():
        x = np.random.default_rng(100 + m).random((200, m)).astype(dtype)
        tree = kdray.KDTree(data)
        assert tree.dtype == dtype and (tree.n, tree.m) == data.shape
        for k in (1, 7):
            d, i = tree.query(x, k=k)
            bd, bi = brute(data, x, k)
            if k == 1:
                bd, bi = bd[:, 0], bi[:, 0]
            assert d.dtype == dtype and i.dtype == np.int64
            np.testing.assert_array_equal(d, bd, err_msg=f"{name} k={k}")
            np.testing.assert_array_equal(i, bi, err_msg=f"{name} k={k}")
            sd, si = cKDTree(data.astype(np.float64)).query(x.astype(np.float64), k=k)
            rtol = 1e-5 if dtype == np.float32 else 1e-12
            np.testing.assert_allclose(d, sd, rtol=rtol, atol=1e-6)
            # Indices equal up to distance ties: where scipy's differs, the distance is the same.
            differ = i != si
            if differ.any():
                q = np.broadcast_to(x[:, None, :] if k > 1 else x, (*si.shape, m))
                np.testing.assert_allclose(
                    np.linalg.norm(data[si[differ]] - q[differ], axis=-1), d[differ], rtol=rtol, atol=1e-6
                )


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_distance_upper_bound_and_missing_neighbours(dtype: type) -> None:
    data = point_sets(1000, 3, dtype, 1)["uniform"]
    x = np.random.default_rng(2).random((300, 3)).astype(dtype)
    tree, ref = kdray.KDTree(data), cKDTree(data.astype(np.float64))
    for ub in (0.02, 0.05, 0.1):
        d, i = tree.query(x, k=5, distance_upper_bound=ub)
        sd, _ = ref.query(x.astype(np.float64), k=5, distance_upper_bound=ub)
        assert np.all((d < ub) | np.isinf(d))
        np.testing.assert_array_equal(np.isinf(d), i == tree.n)
        # Away from the bound itself, the same neighbours are found.
        near = np.abs(sd - ub) > 1e-5
        np.testing.assert_array_equal(np.isinf(d)[near], np.isinf(sd)[near])
    # k past n: padded with inf / n, as scipy.
    d, i = kdray.KDTree(data[:3]).query(x[:2], k=5)
    assert d.shape == (2, 5)
    assert np.all(np.isinf(d[:, 3:])) and np.all(i[:, 3:] == 3)
    # Nothing within zero.
    d, i = tree.query(x[:4], distance_upper_bound=0)
    assert np.all(np.isinf(d)) and np.all(i == tree.n)


def test_query_shapes_like_scipy() -> None:
    data = np.random.default_rng(3).random((500, 3))
    tree, ref = kdray.KDTree(data), cKDTree(data)
    for x in (data[0] + 0.01, data[:10] + 0.01, (data[:12] + 0.01).reshape(3, 4, 3)):
        for k in (1, 3, [1], [2, 4], [3]):
            d, i = tree.query(x, k=k)
            sd, si = ref.query(x, k=k)
            assert np.shape(d) == np.shape(sd) and np.shape(i) == np.shape(si), (np.shape(x), k)
            np.testing.assert_allclose(d, sd, rtol=1e-12)
            np.testing.assert_array_equal(i, si)
    d, i = tree.query(data[0], k=1)
    assert np.ndim(d) == 0 and int(i) == 0


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_query_ball_point_equals_scipy(dtype: type) -> None:
    for m in (2, 3, 6):
        for name, data in point_sets(2000, m, dtype, m).items():
            x = np.random.default_rng(7).random((100, m)).astype(dtype)
            tree, ref = kdray.KDTree(data), cKDTree(data.astype(np.float64))
            r = 0.3 if name != "dup" else 1.5
            got = tree.query_ball_point(x, r)
            want = ref.query_ball_point(x.astype(np.float64), r, return_sorted=True)
            assert got.shape == want.shape
            for j, (g, w) in enumerate(zip(got, want)):
                assert g == sorted(g)
                # Only points at the radius itself may differ (rounding in the dtype).
                extra = sorted(set(g) ^ set(w))
                if extra:
                    dist = np.linalg.norm(data[extra].astype(np.float64) - x[j], axis=1)
                    np.testing.assert_allclose(dist, r, rtol=1e-5)
            counts = tree.query_ball_point(x, r, return_length=True)
            np.testing.assert_array_equal(counts, [len(g) for g in got])
    one = kdray.KDTree(np.eye(3)).query_ball_point([0, 0, 0], 1.0)
    assert one == [0, 1, 2]
    radii = kdray.KDTree(np.eye(3)).query_ball_point(np.zeros((2, 3)), [0.5, 1.0])
    assert list(radii) == [[], [0, 1, 2]]


def test_query_ball_point_is_exact() -> None:
    data = np.random.default_rng(8).random((3000, 3)).astype(np.float32)
    x = np.random.default_rng(9).random((50, 3)).astype(np.float32)
    r = np.float32(0.2)
    got = kdray.KDTree(data).query_ball_point(x, r)
    diff = x[:, None, :] - data[None]
    d2 = diff[..., 0] * diff[..., 0] + diff[..., 1] * diff[..., 1] + diff[..., 2] * diff[..., 2]
    for g, row in zip(got, d2 <= r * r):
        assert g == np.flatnonzero(row).tolist()


def test_data_and_blob_round_trip(tmp_path: object) -> None:
    data = np.random.default_rng(10).random((777, 4)).astype(np.float32)
    tree = kdray.KDTree(data, leafsize=8)
    np.testing.assert_array_equal(tree.data, data)
    again = kdray.KDTree.from_bytes(tree.to_bytes())
    x = data[:50] + 0.001
    for a, b in zip(tree.query(x, k=4), again.query(x, k=4)):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("workers", [1, 2, -1])
def test_workers_answer_alike(workers: int) -> None:
    data = np.random.default_rng(11).random((5000, 3))
    x = np.random.default_rng(12).random((3000, 3))
    tree = kdray.KDTree(data)
    d1, i1 = tree.query(x, k=3)
    d, i = tree.query(x, k=3, workers=workers)
    np.testing.assert_array_equal(d, d1)
    np.testing.assert_array_equal(i, i1)


def test_integer_data_is_float64_and_eps_is_exact() -> None:
    data = np.arange(30).reshape(10, 3)
    tree = kdray.KDTree(data)
    assert tree.dtype == np.float64
    _, i = tree.query([[0, 1, 2.2]], k=2, eps=0.5)
    np.testing.assert_array_equal(i, [[0, 1]])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_distance_upper_bound_is_strict_as_scipy(dtype: type) -> None:
    # The unit points are at distance exactly 1 from the origin.
    data = np.vstack([np.eye(3), [[2, 2, 2]]]).astype(dtype)
    tree, ref = kdray.KDTree(data), cKDTree(data.astype(np.float64))
    for ub in (1.0, float(np.nextafter(dtype(1), dtype(2)))):
        d, i = tree.query(np.zeros(3, dtype), k=4, distance_upper_bound=ub)
        sd, si = ref.query(np.zeros(3), k=4, distance_upper_bound=ub)
        np.testing.assert_array_equal(d, sd.astype(dtype))
        np.testing.assert_array_equal(np.sort(i), np.sort(si))  # equal distances: any order in scipy
        np.testing.assert_array_equal(i, np.sort(i))  # the lower index first in kdray
    assert kdray.KDTree(data).query_ball_point([0, 0, 0], 1.0) == [0, 1, 2]  # inclusive, as scipy
