"""TriangleTree: every ray query equals the kernel's brute force bit for bit."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import camera_rays, kdray_cli, random_rays, sphere

import kdray


def bits(a: np.ndarray) -> np.ndarray:
    """The raw bits of a float32/uint32 array, so NaN and -0 compare exactly."""
    return np.ascontiguousarray(a).view(np.uint32)


def assert_cast_equal(got: dict[str, np.ndarray], want: tuple[np.ndarray, ...]) -> None:
    names = ["t_hit", "primitive_ids", "primitive_uvs", "primitive_normals"]
    for name, w in zip(names, want):
        g = got[name].reshape(w.shape)
        assert g.dtype == w.dtype, name
        np.testing.assert_array_equal(bits(g), bits(w), err_msg=name)


def rays_for(tree: kdray.TriangleTree, n: int, seed: int) -> np.ndarray:
    lo, hi = tree.bounds
    pad = (hi - lo) * 0.2
    return random_rays(n, lo - pad, hi + pad, seed)


def kernel_layout(rays: np.ndarray, tnear: float = 0.0, tfar: float = np.inf) -> np.ndarray:
    out = np.empty((len(rays), 8), np.float32)
    out[:, 0:3], out[:, 3], out[:, 4:7], out[:, 7] = rays[:, :3], tnear, rays[:, 3:], tfar
    return out


def test_cast_rays_equals_brute_force(mesh: tuple[np.ndarray, np.ndarray]) -> None:
    tree = kdray.TriangleTree(*mesh)
    rays = rays_for(tree, 3000, 1)
    got = tree.cast_rays(rays)
    want = tree._tree.cast_brute(kernel_layout(rays))
    assert_cast_equal(got, want)
    assert (got["primitive_ids"] != kdray.MISS).sum() > 100
    miss = got["primitive_ids"] == kdray.MISS
    assert np.all(np.isinf(got["t_hit"][miss]))
    assert np.all(got["primitive_normals"][miss] == 0)
    hit = ~miss
    np.testing.assert_allclose(np.linalg.norm(got["primitive_normals"][hit], axis=1), 1, rtol=1e-5)


@pytest.mark.parametrize("packet", [None, 1, 4, 8, 16])
@pytest.mark.parametrize("nthreads", [0, 1, 3])
def test_every_path_answers_alike(
    sphere_tree: kdray.TriangleTree, packet: int | None, nthreads: int
) -> None:
    # Batches past the serial limit go to the pool; camera rays are coherent.
    lo, hi = sphere_tree.bounds
    cam = camera_rays(64, 48, lo, hi).reshape(-1, 6)
    rnd = rays_for(sphere_tree, 5000, 2)
    for rays in (cam, rnd):
        got = sphere_tree.cast_rays(rays, nthreads, packet=packet)
        assert_cast_equal(got, sphere_tree._tree.cast_brute(kernel_layout(rays)))
        occ = sphere_tree.test_occlusions(rays, nthreads=nthreads, packet=packet)
        np.testing.assert_array_equal(occ, sphere_tree._tree.occluded_brute(kernel_layout(rays)))


def test_large_shadow_batch_in_morton_order_answers_alike() -> None:
    # Past 16,384 scattered any-hit rays the tools trace in Morton order.
    v, f = sphere(12, 24)
    tree = kdray.TriangleTree(v, f)
    rng = np.random.default_rng(3)
    o = rng.normal(size=(40_000, 3))
    o /= np.linalg.norm(o, axis=1, keepdims=True) / 0.9
    d = rng.normal(size=(40_000, 3))
    rays = np.hstack([o, d]).astype(np.float32)
    tfar = rng.random(40_000).astype(np.float32)
    occ = tree.test_occlusions(rays, tnear=0.0, tfar=tfar)
    layout = kernel_layout(rays)
    layout[:, 7] = tfar
    np.testing.assert_array_equal(occ, tree._tree.occluded_brute(layout))
    assert 0 < occ.sum() < len(occ)


def test_leading_shape_and_split_form(sphere_tree: kdray.TriangleTree) -> None:
    lo, hi = sphere_tree.bounds
    cam = camera_rays(20, 10, lo, hi)
    got = sphere_tree.cast_rays(cam)
    assert got["t_hit"].shape == (10, 20)
    assert got["primitive_ids"].shape == (10, 20)
    assert got["primitive_uvs"].shape == (10, 20, 2)
    assert got["primitive_normals"].shape == (10, 20, 3)
    flat = sphere_tree.cast_rays(cam.reshape(-1, 6))
    for k in got:
        np.testing.assert_array_equal(got[k].reshape(flat[k].shape), flat[k])
    apart = sphere_tree.cast_rays(origins=cam[..., :3], directions=cam[..., 3:].astype(np.float64))
    for k in got:
        np.testing.assert_array_equal(apart[k], got[k])
    one = sphere_tree.cast_rays(cam[0, 0])
    assert one["t_hit"].shape == ()
    assert one["primitive_uvs"].shape == (2,)
    empty = sphere_tree.cast_rays(np.zeros((0, 6)))
    assert empty["t_hit"].shape == (0,)


def test_ray_ranges(sphere_tree: kdray.TriangleTree) -> None:
    # From the centre every ray hits the unit sphere at t ~ 1 (unit directions).
    rng = np.random.default_rng(4)
    d = rng.normal(size=(500, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rays = np.hstack([np.zeros((500, 3)), d]).astype(np.float32)
    assert sphere_tree.test_occlusions(rays).all()
    assert not sphere_tree.test_occlusions(rays, tfar=0.5).any()
    assert not sphere_tree.test_occlusions(rays, tnear=1.5).any()
    tfar = np.where(np.arange(500) % 2 == 0, 0.5, 2.0).astype(np.float32)
    np.testing.assert_array_equal(sphere_tree.test_occlusions(rays, tfar=tfar), np.arange(500) % 2 == 1)
    got = sphere_tree.cast_rays(origins=rays[:, :3], directions=rays[:, 3:], tfar=tfar)
    assert np.all(np.isinf(got["t_hit"][::2]))
    assert np.all(np.abs(got["t_hit"][1::2] - 1) < 0.01)


def test_nan_rays_miss(sphere_tree: kdray.TriangleTree) -> None:
    rays = np.array(
        [[np.nan, 0, 0, 1, 0, 0], [0, 0, 0, np.nan, 0, 0], [0, 0, 0, 0, 0, 0], [0, 0, 0, 1, 0, 0]],
        np.float32,
    )
    got = sphere_tree.cast_rays(rays)
    np.testing.assert_array_equal(got["primitive_ids"][:3], [kdray.MISS] * 3)
    assert got["primitive_ids"][3] != kdray.MISS
    np.testing.assert_array_equal(sphere_tree.test_occlusions(rays), [False, False, False, True])


def test_list_intersections_equal_brute_force(mesh: tuple[np.ndarray, np.ndarray]) -> None:
    tree = kdray.TriangleTree(*mesh)
    rays = rays_for(tree, 2000, 5)
    got = tree.list_intersections(rays)
    splits, t, ids, uvs = tree._tree.hits_brute(kernel_layout(rays))
    np.testing.assert_array_equal(got["ray_splits"], splits.astype(np.int64))
    np.testing.assert_array_equal(bits(got["t_hit"]), bits(t))
    np.testing.assert_array_equal(got["primitive_ids"], ids)
    np.testing.assert_array_equal(bits(got["primitive_uvs"]), bits(uvs))
    counts = np.diff(got["ray_splits"])
    np.testing.assert_array_equal(got["ray_ids"], np.repeat(np.arange(len(rays)), counts))
    np.testing.assert_array_equal(tree.count_intersections(rays), counts)
    assert counts.max() > 1
    # The first of each ray's list is its closest hit.
    cast = tree.cast_rays(rays)
    has = counts > 0
    first = got["ray_splits"][:-1][has]
    np.testing.assert_array_equal(got["primitive_ids"][first], cast["primitive_ids"][has])


def test_list_intersections_many_hits_a_ray() -> None:
    # 200 parallel planes: a ray through all of them has 200 hits (past the
    # first buffer's 16 slots, doubled until it holds them).
    n = 200
    z = np.arange(n, dtype=np.float64)
    v = np.concatenate(
        [np.stack([np.full(n, -1.0), np.full(n, -1.0), z], 1),
         np.stack([np.full(n, 3.0), np.full(n, -1.0), z], 1),
         np.stack([np.full(n, -1.0), np.full(n, 3.0), z], 1)]
    )
    f = np.stack([np.arange(n), np.arange(n) + n, np.arange(n) + 2 * n], 1)
    tree = kdray.TriangleTree(v, f)
    rays = np.array([[0.1, 0.2, -1, 0, 0, 1], [0.1, 0.2, 50.5, 0, 0, 1], [5, 5, -1, 0, 0, 1]], np.float32)
    got = tree.list_intersections(rays)
    np.testing.assert_array_equal(got["ray_splits"], [0, n, n + n - 51, n + n - 51])
    np.testing.assert_array_equal(got["primitive_ids"][:n], np.arange(n))
    np.testing.assert_array_equal(tree.count_intersections(rays), [n, n - 51, 0])


def test_shared_meshes_equal_brute_force(shared_mesh: Path) -> None:
    tree = kdray.TriangleTree.from_file(shared_mesh)
    rays = rays_for(tree, 2000, 6)
    assert_cast_equal(tree.cast_rays(rays), tree._tree.cast_brute(kernel_layout(rays)))
    np.testing.assert_array_equal(tree.test_occlusions(rays), tree._tree.occluded_brute(kernel_layout(rays)))
    lo, hi = tree.bounds
    cam = camera_rays(64, 64, lo, hi).reshape(-1, 6)
    assert_cast_equal(tree.cast_rays(cam, packet=8), tree._tree.cast_brute(kernel_layout(cam)))


def test_equals_the_cli(shared_mesh: Path, tmp_path: Path) -> None:
    cli = kdray_cli()
    if cli is None:
        pytest.skip("no kdray binary (cargo build --release, or set KDRAY_BIN)")
    blob = tmp_path / "mesh.kdt"
    subprocess.run([cli, "build", shared_mesh, "-o", blob], check=True, capture_output=True)
    built = kdray.TriangleTree.from_file(shared_mesh)
    assert built.to_bytes() == blob.read_bytes()  # the same builder, the same bytes
    tree = kdray.TriangleTree.load(blob)
    rays = rays_for(tree, 4000, 8)
    ray_file, hit_file = tmp_path / "r.rays", tmp_path / "h.hits"
    kernel_layout(rays).tofile(ray_file)
    for flag, query in ((None, "closest"), ("--any-hit", "any")):
        cmd = [cli, "trace", blob, ray_file, "-o", hit_file] + ([flag] if flag else [])
        subprocess.run(cmd, check=True, capture_output=True)
        hits = np.fromfile(hit_file, dtype=np.float32).reshape(-1, 4)
        if query == "closest":
            got = tree.cast_rays(rays)
            np.testing.assert_array_equal(bits(got["t_hit"]), bits(hits[:, 0]))
            np.testing.assert_array_equal(got["primitive_ids"], bits(hits[:, 1]))
            np.testing.assert_array_equal(bits(got["primitive_uvs"]), bits(hits[:, 2:4]))
        else:
            np.testing.assert_array_equal(tree.test_occlusions(rays), bits(hits[:, 1]) != kdray.MISS)


def test_blob_round_trips(sphere_tree: kdray.TriangleTree, tmp_path: Path) -> None:
    blob = sphere_tree.to_bytes()
    assert isinstance(blob, bytes)
    assert sphere_tree.to_bytes() is blob  # held as bytes: no copy
    rays = rays_for(sphere_tree, 500, 9)
    want = sphere_tree.cast_rays(rays)
    for source in (blob, memoryview(blob), bytearray(blob), memoryview(blob)[0:]):
        again = kdray.TriangleTree.from_bytes(source)
        assert again.to_bytes() == blob
        assert_cast_equal(again.cast_rays(rays), tuple(want.values()))
    # An unaligned read-only view is copied once, then answers alike.
    shifted = memoryview(b"\0" + blob)[1:]
    assert_cast_equal(kdray.TriangleTree.from_bytes(shifted).cast_rays(rays), tuple(want.values()))
    path = tmp_path / "sphere.kdt"
    sphere_tree.save(path)
    assert path.read_bytes() == blob
    assert kdray.TriangleTree.load(path).to_bytes() == blob


def test_a_copied_blob_does_not_see_later_writes(sphere_tree: kdray.TriangleTree) -> None:
    buf = bytearray(sphere_tree.to_bytes())
    tree = kdray.TriangleTree.from_bytes(buf)  # writable: copied
    buf[:] = bytes(len(buf))
    rays = rays_for(sphere_tree, 200, 10)
    assert_cast_equal(tree.cast_rays(rays), tuple(sphere_tree.cast_rays(rays).values()))


def test_builders_agree(mesh: tuple[np.ndarray, np.ndarray]) -> None:
    rays = rays_for(kdray.TriangleTree(*mesh), 1000, 11)
    want = None
    for builder in ("sah", "sweep", "binned", "fast", "median", "middle"):
        tree = kdray.TriangleTree(*mesh, builder=builder, threads=1)
        got = tuple(tree.cast_rays(rays).values())
        if want is None:
            want = got
        assert_cast_equal(dict(zip(["t_hit", "primitive_ids", "primitive_uvs", "primitive_normals"], got)), want)
    shallow = kdray.TriangleTree(*mesh, max_depth=4)
    assert shallow.depth <= 4
    assert want is not None
    assert_cast_equal(shallow.cast_rays(rays), want)


def test_golden_blob_loads() -> None:
    cube = Path(__file__).resolve().parents[2] / "kernel" / "golden" / "cube-v3.kdt"
    tree = kdray.TriangleTree.load(cube)
    assert tree.triangle_count == 14
    got = tree.cast_rays(np.array([0.3, 0.6, -1.0, 0, 0, 1], np.float32))
    assert (float(got["t_hit"]), int(got["primitive_ids"])) == (1.0, 1)
