"""kdray.dask: blocks of a row-chunked dask array answer as the direct call."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_rays, sphere

import kdray

da = pytest.importorskip("dask.array")
distributed = pytest.importorskip("distributed")
import dask

import kdray.dask as kd


def inputs() -> tuple[kdray.TriangleTree, np.ndarray, kdray.KDTree, np.ndarray]:
    v, f = sphere()
    rays = random_rays(20_000, np.array([-2.0] * 3), np.array([2.0] * 3), 1)
    pts = np.random.default_rng(2).random((5000, 3)).astype(np.float32)
    x = np.random.default_rng(3).random((7000, 3)).astype(np.float32)
    return kdray.TriangleTree(v, f), rays, kdray.KDTree(pts), x


def check(tree: kdray.TriangleTree, rays: np.ndarray, kd_tree: kdray.KDTree, x: np.ndarray) -> None:
    hits = kd.cast_rays(tree, da.from_array(rays, chunks=(3000, 6)))
    got = dict(zip(hits, dask.compute(*hits.values())))
    want = tree.cast_rays(rays)
    assert got.keys() == want.keys()
    for k in want:
        assert got[k].dtype == want[k].dtype and got[k].shape == want[k].shape, k
        np.testing.assert_array_equal(got[k].view(np.uint32), want[k].view(np.uint32), err_msg=k)
    check_distances(tree, rays[:, :3] * np.float32(0.7))
    for k in (1, 4):
        d, i = dask.compute(*kd.query(kd_tree, da.from_array(x, chunks=(1500, 3)), k=k))
        wd, wi = kd_tree.query(x, k=k)
        np.testing.assert_array_equal(d, wd)
        np.testing.assert_array_equal(i, wi)


def check_distances(tree: kdray.TriangleTree, q: np.ndarray) -> None:
    dq = da.from_array(q, chunks=(3000, 3))
    cp = kd.compute_closest_points(tree, dq)
    got = dict(zip(cp, dask.compute(*cp.values())))
    want = tree.compute_closest_points(q)
    assert got.keys() == want.keys()
    for k in want:
        assert got[k].dtype == want[k].dtype and got[k].shape == want[k].shape, k
        np.testing.assert_array_equal(got[k].view(np.uint32), want[k].view(np.uint32), err_msg=k)
    for name, kwargs in (
        ("compute_distance", {}),
        ("compute_signed_distance", {"nsamples": 3}),
        ("compute_signed_distance", {"winding": True}),
        ("compute_occupancy", {"nsamples": 1}),
    ):
        g = getattr(kd, name)(tree, dq, **kwargs).compute()
        w = getattr(tree, name)(q, **kwargs)
        assert g.dtype == w.dtype == np.float32 and g.shape == w.shape, name
        np.testing.assert_array_equal(g.view(np.uint32), w.view(np.uint32), err_msg=name)


def test_local_scheduler() -> None:
    check(*inputs())


def test_two_worker_processes() -> None:
    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster),
    ):
        check(*inputs())


def test_scene_distances_by_blocks(tmp_path_factory: pytest.TempPathFactory) -> None:
    from test_scene import built_scene

    scene = kdray.Scene.load(built_scene(tmp_path_factory, squash=False))
    q = (np.random.default_rng(5).random((4000, 3)) * 8 - 4).astype(np.float32)
    dq = da.from_array(q, chunks=(1500, 3))
    cp = kd.compute_closest_points(scene, dq)
    got = dict(zip(cp, dask.compute(*cp.values())))
    want = scene.compute_closest_points(q)
    assert got.keys() == want.keys()
    for k in want:
        np.testing.assert_array_equal(got[k].view(np.uint32), want[k].view(np.uint32), err_msg=k)
    d = kd.compute_distance(scene, dq).compute()
    np.testing.assert_array_equal(d, scene.compute_distance(q))
    with pytest.raises(TypeError, match="TriangleTree"):
        kd.compute_occupancy(scene, dq)  # type: ignore[arg-type]


def test_wrong_arrays_are_refused() -> None:
    tree, _, kd_tree, _ = inputs()
    with pytest.raises(ValueError, match="rays"):
        kd.cast_rays(tree, da.zeros((10, 5)))
    with pytest.raises(TypeError, match="tree"):
        kd.cast_rays(kd_tree, da.zeros((10, 6)))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="x"):
        kd.query(kd_tree, da.zeros((10, 4)))
    with pytest.raises(ValueError, match="query_points"):
        kd.compute_distance(tree, da.zeros((10, 6)))
    with pytest.raises(TypeError, match="tree"):
        kd.compute_closest_points(kd_tree, da.zeros((10, 3)))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="nsamples"):
        kd.compute_occupancy(tree, da.zeros((10, 3)), nsamples=4)
