"""Scene: a scene blob of instanced meshes answers as its brute force, naming instances."""

from __future__ import annotations

import base64
import json
import pickle
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import kdray_cli, random_rays, soup, sphere

import kdray


def gltf(path: Path, squash: bool = False) -> None:
    """A glTF file of two meshes placed by four nodes (one scaled, one rotated; ``squash``: a fifth scaled unevenly)."""
    meshes = [sphere(8, 16), soup(200, 3)]
    blob, views, accessors, gl_meshes = b"", [], [], []
    for v, f in meshes:
        for arr, ctype, kind in ((v.astype(np.float32), 5126, "VEC3"), (f.astype(np.uint32).ravel(), 5125, "SCALAR")):
            data = arr.tobytes()
            views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
            acc = {"bufferView": len(views) - 1, "componentType": ctype, "count": len(arr), "type": kind}
            if kind == "VEC3":
                acc["min"], acc["max"] = arr.min(0).tolist(), arr.max(0).tolist()
            accessors.append(acc)
            blob += data
        gl_meshes.append({"primitives": [{"attributes": {"POSITION": len(accessors) - 2}, "indices": len(accessors) - 1}]})
    nodes = [
        {"mesh": 0},
        {"mesh": 0, "translation": [3, 0, 0]},
        {"mesh": 1, "translation": [0, 3, 0], "scale": [2, 2, 2]},
        {"mesh": 1, "rotation": [0, 0, 0.7071068, 0.7071068], "translation": [0, -3, 0]},
    ]
    if squash:
        nodes.append({"mesh": 0, "translation": [0, 0, 6], "scale": [1, 0.5, 1]})
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": gl_meshes,
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    path.write_text(json.dumps(doc))


@pytest.fixture(scope="module")
def scene_blob(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return built_scene(tmp_path_factory, squash=False)


def built_scene(tmp_path_factory: pytest.TempPathFactory, squash: bool) -> Path:
    cli = kdray_cli()
    if cli is None:
        pytest.skip("no kdray binary (cargo build --release, or set KDRAY_BIN)")
    d = tmp_path_factory.mktemp("scene")
    gltf(d / "scene.gltf", squash)
    subprocess.run([cli, "build", d / "scene.gltf", "--instances", "-o", d / "scene.kdt"], check=True, capture_output=True)
    return d / "scene.kdt"


def kernel_layout(rays: np.ndarray) -> np.ndarray:
    out = np.zeros((len(rays), 8), np.float32)
    out[:, 0:3], out[:, 4:7], out[:, 7] = rays[:, :3], rays[:, 3:], np.inf
    return out


def test_scene_equals_brute_force(scene_blob: Path) -> None:
    scene = kdray.Scene.load(scene_blob)
    assert (scene.instance_count, scene.mesh_count) == (4, 2)
    rays = random_rays(5000, np.array([-4.0, -5, -2]), np.array([5.0, 6, 2]), 1)
    got = scene.cast_rays(rays)
    want = scene._tree.cast_brute(kernel_layout(rays))
    names = ["t_hit", "geometry_ids", "primitive_ids", "primitive_uvs", "primitive_normals"]
    assert list(got) == names
    for name, w in zip(names, want):
        np.testing.assert_array_equal(got[name].view(np.uint32), w.view(np.uint32), err_msg=name)
    assert set(np.unique(got["geometry_ids"])) == {0, 1, 2, 3, kdray.MISS}
    np.testing.assert_array_equal(scene.test_occlusions(rays), scene._tree.occluded_brute(kernel_layout(rays)))
    lists = scene.list_intersections(rays)
    counts = np.diff(lists["ray_splits"])
    np.testing.assert_array_equal(scene.count_intersections(rays), counts)
    has = counts > 0
    first = lists["ray_splits"][:-1][has]
    for name in ("t_hit", "geometry_ids", "primitive_ids"):
        np.testing.assert_array_equal(lists[name][first], got[name][has])


def test_scene_blob_round_trips(scene_blob: Path, tmp_path: Path) -> None:
    scene = kdray.Scene.load(scene_blob)
    blob = scene_blob.read_bytes()
    assert scene.to_bytes() == blob
    for again in (kdray.Scene.from_bytes(blob), pickle.loads(pickle.dumps(scene, protocol=5))):
        assert again.to_bytes() == blob
    scene.save(tmp_path / "again.kdt")
    assert (tmp_path / "again.kdt").read_bytes() == blob
    with pytest.raises(kdray.BlobError, match="scene"):
        kdray.Scene.from_bytes(blob[:-8])


def test_scene_distances_equal_brute_force(scene_blob: Path) -> None:
    scene = kdray.Scene.load(scene_blob)
    rng = np.random.default_rng(4)
    q = (rng.random((3000, 3)) * [10, 12, 5] - [4, 6, 2.5]).astype(np.float32)
    got = scene.compute_closest_points(q.reshape(30, 100, 3))
    names = ["points", "geometry_ids", "primitive_ids", "primitive_uvs", "primitive_normals"]
    assert list(got) == names
    assert got["points"].shape == (30, 100, 3) and got["geometry_ids"].shape == (30, 100)
    points, inst, prim, uvs, d2 = scene._tree.closest_points_brute(q)
    for name, want in (("points", points), ("geometry_ids", inst), ("primitive_ids", prim), ("primitive_uvs", uvs)):
        g = got[name].reshape(want.shape)
        np.testing.assert_array_equal(g.view(np.uint32), want.view(np.uint32), err_msg=name)
    assert set(np.unique(inst)) == {0, 1, 2, 3}
    normals = got["primitive_normals"].reshape(-1, 3)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, rtol=1e-5)
    d = scene.compute_distance(q)
    np.testing.assert_array_equal(d, np.sqrt(d2).astype(np.float32))
    # The point reported lies at the distance reported.
    np.testing.assert_allclose(np.linalg.norm(points - q, axis=1), d, rtol=1e-4, atol=1e-5)
    for threads in (1, 2):
        np.testing.assert_array_equal(scene.compute_distance(q, nthreads=threads), d)


def test_scene_distances_refuse_what_they_cannot_answer(
    scene_blob: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    scene = kdray.Scene.load(scene_blob)
    bad = np.array([[np.nan, 0, 0], [0, np.inf, 0], [0.5, 0.5, 0.5]], np.float32)
    d = scene.compute_distance(bad)
    assert np.isnan(d[:2]).all() and np.isfinite(d[2])
    cp = scene.compute_closest_points(bad)
    assert (cp["geometry_ids"][:2] == kdray.MISS).all() and (cp["primitive_ids"][:2] == kdray.MISS).all()
    assert np.isnan(cp["points"][:2]).all() and (cp["primitive_normals"][:2] == 0).all()
    assert scene.compute_distance(np.zeros((0, 3))).shape == (0,)
    with pytest.raises(ValueError, match="query_points"):
        scene.compute_distance(np.zeros((4, 2)))
    with pytest.raises(NotImplementedError, match="not offered on a Scene"):
        scene.compute_signed_distance(bad)
    with pytest.raises(NotImplementedError, match="not offered on a Scene"):
        scene.compute_occupancy(bad)
    squashed = kdray.Scene.load(built_scene(tmp_path_factory, squash=True))
    with pytest.raises(ValueError, match="instance 4 is scaled unevenly"):
        squashed.compute_distance(bad)
    with pytest.raises(ValueError, match="instance 4"):
        squashed.compute_closest_points(bad)
    # Its rays still trace.
    assert squashed.cast_rays(np.array([[0, 0, 9, 0, 0, -1]], np.float32))["geometry_ids"][0] == 4
