# ruff: noqa: B023  (the timed lambdas run inside their own loop pass)
"""kdray beside the Python peers on the same arrays, one table of ratios.

Run in the peers' venv (``bash ../shared/anchors/python/setup.sh``), with
kdray installed there or on ``PYTHONPATH``, pinned to one core::

    /work/bin/slot --quiet taskset -c 0 env OMP_NUM_THREADS=1 \\
        $(bash ../shared/anchors/python/setup.sh) python/bench/bench.py [--quick]

Every row is ``peer seconds / kdray seconds`` (above 1: kdray is faster),
the best of ``--reps`` interleaved passes. Meshes come from
``../shared/meshes`` (``KDRAY_MESHES=DIR`` for another folder).
"""

from __future__ import annotations

import argparse
import os
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import kdray

MESHES = Path(
    os.environ.get("KDRAY_MESHES", Path(__file__).resolve().parents[3] / "shared" / "meshes")
)


def best(reps: int, *calls: Callable[[], Any]) -> list[float]:
    """The best seconds of each call over ``reps`` interleaved passes."""
    out = [np.inf] * len(calls)
    for _ in range(reps):
        for j, c in enumerate(calls):
            t = time.perf_counter()
            c()
            out[j] = min(out[j], time.perf_counter() - t)
    return out


def load(name: str) -> tuple[np.ndarray, np.ndarray]:
    """The mesh's triangles as every peer takes them: 3 vertices each, in the tools' loader's order."""
    tris = kdray.TriangleTree.from_file(MESHES / name, builder="fast").triangles
    return tris.reshape(-1, 3), np.arange(3 * len(tris), dtype=np.uint32).reshape(-1, 3)


def camera(v: np.ndarray, n: int) -> np.ndarray:
    lo, hi = v.min(0), v.max(0)
    c, ext = (lo + hi) / 2, float(np.max(hi - lo))
    side = int(np.sqrt(n))
    ys, xs = np.meshgrid(np.linspace(-0.5, 0.5, side), np.linspace(-0.5, 0.5, side), indexing="ij")
    d = np.stack([xs * 0.7, ys * 0.7, np.ones_like(xs)], -1).reshape(-1, 3)
    o = np.broadcast_to(c - [0, 0, 1.4 * ext], d.shape)
    return np.hstack([o, d]).astype(np.float32)


def scattered(v: np.ndarray, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo, hi = v.min(0), v.max(0)
    o = lo + (hi - lo) * rng.random((n, 3))
    d = rng.normal(size=(n, 3))
    return np.hstack([o, d]).astype(np.float32)


def shadow(v: np.ndarray, f: np.ndarray, n: int, seed: int) -> tuple[np.ndarray, float, float]:
    """Rays from random surface points towards a light above the mesh: (rays, tnear, tfar)."""
    rng = np.random.default_rng(seed)
    tri = v[f[rng.integers(0, len(f), n)]]
    a, b = rng.random((2, n, 1))
    flip = a + b > 1
    a, b = np.where(flip, 1 - a, a), np.where(flip, 1 - b, b)
    p = tri[:, 0] + a * (tri[:, 1] - tri[:, 0]) + b * (tri[:, 2] - tri[:, 0])
    lo, hi = v.min(0), v.max(0)
    light = (lo + hi) / 2 + [0, 2 * float(np.max(hi - lo)), 0]
    return np.hstack([p, light - p]).astype(np.float32), 1e-4, 1 - 1e-4


def cli_seconds(tree: kdray.TriangleTree, rays: np.ndarray) -> float | None:
    """``kdray trace --threads 1``'s own timing of the same rays (file I/O excluded), if the CLI is built."""
    import json
    import subprocess
    import tempfile

    cli = Path(__file__).resolve().parents[2] / "target" / "release" / "kdray"
    if not cli.is_file():
        return None
    with tempfile.TemporaryDirectory() as d:
        tree.save(Path(d) / "t.kdt")
        layout = np.zeros((len(rays), 8), np.float32)
        layout[:, 0:3], layout[:, 4:7], layout[:, 7] = rays[:, :3], rays[:, 3:], np.inf
        layout.tofile(Path(d) / "r.rays")
        out = subprocess.run(
            [
                cli,
                "trace",
                Path(d) / "t.kdt",
                Path(d) / "r.rays",
                "-o",
                Path(d) / "h",
                "--threads",
                "1",
                "--json",
                "--repeat",
                "3",
            ],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        return float(json.loads(out)["seconds"])


def rays_rows(rows: list[tuple[str, float]], n: int, reps: int) -> None:
    import open3d as o3d
    import trimesh

    for name in ("stanford-bunny.obj", "sponza.obj"):
        if not (MESHES / name).is_file():
            print(f"# {name}: not found, skipped")
            continue
        v, f = load(name)
        t0 = time.perf_counter()
        tree = kdray.TriangleTree(v, f)
        kd_build = time.perf_counter() - t0
        scene1 = o3d.t.geometry.RaycastingScene(nthreads=1)
        scene1.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f))
        scene_all = o3d.t.geometry.RaycastingScene()
        scene_all.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f))
        tm = trimesh.Trimesh(v, f, process=False)
        short = name.split(".")[0].replace("stanford-", "")
        rows.append((f"{short}: kdray build (s), one core", kd_build))
        for kind, rays in (("camera", camera(v, n)), ("random", scattered(v, n, 1))):
            t = o3d.core.Tensor(rays)
            s_kd1, s_kd8, s_o1 = best(
                reps,
                lambda: tree.cast_rays(rays, 1, packet=1),
                lambda: tree.cast_rays(rays, 1),
                lambda: scene1.cast_rays(t, nthreads=1),
            )
            s_kd, s_o = best(reps, lambda: tree.cast_rays(rays), lambda: scene_all.cast_rays(t))
            sub = rays[: n // 10]
            s_kd_s, s_tm = best(
                1,
                lambda: tree.cast_rays(sub, 1),
                lambda: tm.ray.intersects_first(sub[:, :3], sub[:, 3:]),
            )
            rows.append((f"{short} {kind} cast_rays packet=1 vs Open3D, nthreads=1", s_o1 / s_kd1))
            rows.append((f"{short} {kind} cast_rays (default packet=None) vs Open3D, nthreads=1", s_o1 / s_kd8))
            rows.append((f"{short} {kind} cast_rays vs Open3D, all cores", s_o / s_kd))
            rows.append(
                (f"{short} {kind} cast_rays vs trimesh+embreex (1/10 of the rays)", s_tm / s_kd_s)
            )
            rows.append((f"{short} {kind} kdray Mrays/s, nthreads=1", n / s_kd8 / 1e6))
            cli = cli_seconds(tree, rays)
            if cli is not None:
                rows.append(
                    (f"{short} {kind} kdray trace (CLI) seconds / cast_rays seconds", cli / s_kd8)
                )
        rays, tnear, tfar = shadow(v, f, n, 2)
        t = o3d.core.Tensor(rays)
        s_kd, s_kd8, s_o = best(
            reps,
            lambda: tree.test_occlusions(rays, tnear, tfar, 1, packet=1),
            lambda: tree.test_occlusions(rays, tnear, tfar, 1),
            lambda: scene1.test_occlusions(t, tnear=tnear, tfar=tfar, nthreads=1),
        )
        rows.append((f"{short} shadow test_occlusions packet=1 vs Open3D, nthreads=1", s_o / s_kd))
        rows.append((f"{short} shadow test_occlusions (default packet=None) vs Open3D, nthreads=1", s_o / s_kd8))
        one = rays[:1]
        t1 = o3d.core.Tensor(one)
        calls = 2000
        s_kd, s_o = best(
            3,
            lambda: [tree.cast_rays(one, 1) for _ in range(calls)],
            lambda: [scene1.cast_rays(t1, nthreads=1) for _ in range(calls)],
        )
        rows.append((f"{short} one-ray cast_rays: kdray us/call", s_kd / calls * 1e6))
        rows.append((f"{short} one-ray cast_rays: Open3D us/call", s_o / calls * 1e6))


def points_rows(rows: list[tuple[str, float]], n: int, m: int, reps: int) -> None:
    from pykdtree.kdtree import KDTree as PyKDTree
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(3)
    data, x = rng.random((n, 3)), rng.random((m, 3))
    b_kd, b_sp = best(reps, lambda: kdray.KDTree(data), lambda: cKDTree(data, leafsize=16))
    rows.append(("KDTree build vs scipy cKDTree (1M 3-D f64)", b_sp / b_kd))
    kd, sp, pk = kdray.KDTree(data), cKDTree(data, leafsize=16), PyKDTree(data, leafsize=16)
    for k in (1, 10):
        s_kd, s_sp, s_pk = best(
            reps,
            lambda: kd.query(x, k=k),
            lambda: sp.query(x, k=k, workers=1),
            lambda: pk.query(x, k=k),
        )
        rows.append((f"KDTree.query k={k} vs scipy cKDTree (f64, 1 worker)", s_sp / s_kd))
        rows.append(
            (
                f"KDTree.query k={k} vs pykdtree (f64, OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', '?')})",
                s_pk / s_kd,
            )
        )
    d32, x32 = data.astype(np.float32), x.astype(np.float32)
    kd32, pk32 = kdray.KDTree(d32), PyKDTree(d32, leafsize=16)
    for k in (1, 10):
        s_kd, s_sp, s_pk = best(
            reps,
            lambda: kd32.query(x32, k=k),
            lambda: sp.query(x, k=k, workers=1),
            lambda: pk32.query(x32, k=k),
        )
        rows.append((f"KDTree.query k={k} f32 vs scipy cKDTree (its f64)", s_sp / s_kd))
        rows.append((f"KDTree.query k={k} f32 vs pykdtree f32", s_pk / s_kd))
    one = x[:1]
    calls = 5000
    s_kd, s_sp = best(
        3,
        lambda: [kd.query(one) for _ in range(calls)],
        lambda: [sp.query(one) for _ in range(calls)],
    )
    rows.append(("one-query KDTree.query: kdray us/call", s_kd / calls * 1e6))
    rows.append(("one-query cKDTree.query: scipy us/call", s_sp / calls * 1e6))


def near_surface(v: np.ndarray, f: np.ndarray, n: int, seed: int) -> np.ndarray:
    """Points within 1% of the box diagonal of random surface points."""
    rng = np.random.default_rng(seed)
    tri = v[f[rng.integers(0, len(f), n)]].astype(np.float64)
    a, b = rng.random((2, n, 1))
    flip = a + b > 1
    a, b = np.where(flip, 1 - a, a), np.where(flip, 1 - b, b)
    p = tri[:, 0] + a * (tri[:, 1] - tri[:, 0]) + b * (tri[:, 2] - tri[:, 0])
    diag = float(np.linalg.norm(v.max(0) - v.min(0)))
    step = rng.normal(size=(n, 3))
    step *= (rng.random((n, 1)) * 0.01 * diag) / np.linalg.norm(step, axis=1, keepdims=True)
    return (p + step).astype(np.float32)


def distance_rows(rows: list[tuple[str, float]], n: int, reps: int) -> None:
    """Closest points, signed distance and occupancy beside Open3D and trimesh, one thread."""
    import open3d as o3d
    import trimesh

    for name in ("stanford-bunny.obj", "sponza.obj"):
        if not (MESHES / name).is_file():
            print(f"# {name}: not found, skipped")
            continue
        v, f = load(name)
        tree = kdray.TriangleTree(v, f)
        scene = o3d.t.geometry.RaycastingScene(nthreads=1)
        scene.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f))
        tm = trimesh.Trimesh(v, f, process=False)
        short = name.split(".")[0].replace("stanford-", "")
        lo, hi = v.min(0), v.max(0)
        pad = (hi - lo) * 0.1
        uniform = (lo - pad + (hi - lo + 2 * pad) * np.random.default_rng(5).random((n, 3)))
        for kind, q in (("uniform", uniform.astype(np.float32)), ("near", near_surface(v, f, n, 6))):
            t = o3d.core.Tensor(q)
            s_cp, s_ocp = best(
                reps,
                lambda: tree.compute_closest_points(q, 1),
                lambda: scene.compute_closest_points(t, nthreads=1),
            )
            rows.append((f"{short} {kind} compute_closest_points vs Open3D, nthreads=1", s_ocp / s_cp))
            rows.append((f"{short} {kind} kdray closest points k/s, nthreads=1", n / s_cp / 1e3))
            s_sd, s_osd = best(
                reps,
                lambda: tree.compute_signed_distance(q, 1),
                lambda: scene.compute_signed_distance(t, nthreads=1),
            )
            rows.append((f"{short} {kind} compute_signed_distance vs Open3D, nthreads=1", s_osd / s_sd))
            s_oc, s_ooc = best(
                reps,
                lambda: tree.compute_occupancy(q, 1),
                lambda: scene.compute_occupancy(t, nthreads=1),
            )
            rows.append((f"{short} {kind} compute_occupancy vs Open3D, nthreads=1", s_ooc / s_oc))
            try:
                import rtree  # noqa: F401  (trimesh's closest_point needs it)
            except ImportError:
                continue
            sub = q[: max(1, n // 50)]
            s_cp_s, s_tm = best(
                1,
                lambda: tree.compute_closest_points(sub, 1),
                lambda: trimesh.proximity.closest_point(tm, sub),
            )
            rows.append(
                (f"{short} {kind} compute_closest_points vs trimesh (1/50 of the points)", s_tm / s_cp_s)
            )
        one = uniform[:1].astype(np.float32)
        t1 = o3d.core.Tensor(one)
        calls = 2000
        s_kd, s_o = best(
            3,
            lambda: [tree.compute_distance(one, 1) for _ in range(calls)],
            lambda: [scene.compute_distance(t1, nthreads=1) for _ in range(calls)],
        )
        rows.append((f"{short} one-point compute_distance: kdray us/call", s_kd / calls * 1e6))
        rows.append((f"{short} one-point compute_distance: Open3D us/call", s_o / calls * 1e6))


def overhead_rows(rows: list[tuple[str, float]], reps: int) -> None:
    """Per-call microseconds of a batch of one (ray, query point, closest point) beside the peers."""
    import open3d as o3d
    from scipy.spatial import KDTree as ScipyKDTree
    from scipy.spatial import cKDTree

    name = "stanford-bunny.obj"
    if (MESHES / name).is_file():
        v, f = load(name)
    else:
        print(f"# {name}: not found, an icosahedron instead")
        v = np.array(
            [[0, 1, 1.618], [0, -1, 1.618], [0, 1, -1.618], [0, -1, -1.618], [1, 1.618, 0], [-1, 1.618, 0],
             [1, -1.618, 0], [-1, -1.618, 0], [1.618, 0, 1], [-1.618, 0, 1], [1.618, 0, -1], [-1.618, 0, -1]],
            np.float32,
        )
        f = np.array([[0, 1, 8], [1, 0, 9], [2, 3, 11], [3, 2, 10]], np.uint32)
    tree = kdray.TriangleTree(v, f)
    scene = o3d.t.geometry.RaycastingScene(nthreads=1)
    scene.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f))
    ray = scattered(v, 1, 3)
    t_ray = o3d.core.Tensor(ray)
    q = (v.min(0) + (v.max(0) - v.min(0)) * 0.3)[None, :].astype(np.float32)
    t_q = o3d.core.Tensor(q)
    pts = np.random.default_rng(4).random((100_000, 3))
    kd, ck, sk = kdray.KDTree(pts), cKDTree(pts), ScipyKDTree(pts)
    x = pts[:1] * 0.999
    calls = 5000

    def per_call(fn: Callable[[], Any]) -> Callable[[], None]:
        return lambda: [fn() for _ in range(calls)]  # type: ignore[func-returns-value]

    groups: list[tuple[str, list[tuple[str, Callable[[], Any]]]]] = [
        (
            "one-ray cast_rays",
            [
                ("kdray, nthreads=1", lambda: tree.cast_rays(ray, 1)),
                ("kdray, all cores", lambda: tree.cast_rays(ray)),
                ("Open3D, nthreads=1", lambda: scene.cast_rays(t_ray, nthreads=1)),
                ("Open3D, all cores", lambda: scene.cast_rays(t_ray)),
            ],
        ),
        (
            "one-point query (k=1)",
            [
                ("kdray KDTree", lambda: kd.query(x)),
                ("scipy cKDTree", lambda: ck.query(x)),
                ("scipy KDTree", lambda: sk.query(x)),
            ],
        ),
        (
            "one-point compute_closest_points",
            [
                ("kdray, nthreads=1", lambda: tree.compute_closest_points(q, 1)),
                ("kdray, all cores", lambda: tree.compute_closest_points(q)),
                ("Open3D, nthreads=1", lambda: scene.compute_closest_points(t_q, nthreads=1)),
            ],
        ),
        (
            "one-point compute_distance",
            [
                ("kdray, nthreads=1", lambda: tree.compute_distance(q, 1)),
                ("Open3D, nthreads=1", lambda: scene.compute_distance(t_q, nthreads=1)),
            ],
        ),
    ]
    for group, calls_of in groups:
        secs = best(reps, *(per_call(fn) for _, fn in calls_of))
        for (who, _), s in zip(calls_of, secs):
            rows.append((f"{group}: {who}, us/call", s / calls * 1e6))


def dask_rows(rows: list[tuple[str, float]], n: int, reps: int) -> None:
    """Throughput of ``kdray.dask.cast_rays`` on two local worker processes beside one process.

    The rays are made on the workers (as docs/python.md's example does) and
    fetched once for the one-process calls; best of ``reps`` passes each.
    Timed on the cluster: the answers kept on the workers (``persist``), and
    gathered to the client (``compute``, 40 bytes a ray over the wire).
    """
    import dask
    import dask.array as da
    from distributed import Client, LocalCluster, get_task_stream, wait

    import kdray.dask as kd

    if not (MESHES / "stanford-bunny.obj").is_file():
        return
    v, f = load("stanford-bunny.obj")
    tree = kdray.TriangleTree(v, f)
    lo, hi = v.min(0), v.max(0)
    chunk = 1_000_000
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cl,
        Client(cl) as client,
    ):
        client.wait_for_workers(2)
        rng = da.random.default_rng(4)
        origins = lo + (hi - lo) * rng.random((n, 3), chunks=(chunk, 3))
        rays = da.concatenate([origins, rng.normal(size=(n, 3), chunks=(chunk, 3))], axis=1)
        rays = client.persist(rays.astype(np.float32))
        wait(rays)
        local = rays.compute()
        s_one, s_all = best(
            reps, lambda: tree.cast_rays(local, 1), lambda: tree.cast_rays(local, 0)
        )
        s_kept = s_gathered = np.inf
        traced: Counter[str] = Counter()
        for _ in range(reps):
            # New keys each pass (a new scatter): traced again, never read back.
            hits = kd.cast_rays(tree, rays, nthreads=1)
            with get_task_stream(client) as stream:
                t = time.perf_counter()
                kept = client.persist(list(hits.values()))
                wait(kept)
                s_kept = min(s_kept, time.perf_counter() - t)
            traced = Counter(
                str(task["worker"]) for task in stream.data if "_records_block" in str(task["key"])
            )
            del kept
            hits = kd.cast_rays(tree, rays, nthreads=1)
            t = time.perf_counter()
            dask.compute(*hits.values())
            s_gathered = min(s_gathered, time.perf_counter() - t)
        held = client.run(
            lambda dask_worker: sum(
                isinstance(x, kdray.TriangleTree) for x in dask_worker.data.values()
            )
        )
    tag = f"bunny {n / 1e6:g}M random rays"
    rows.append((f"{tag}: one process, nthreads=1, Mrays/s", n / s_one / 1e6))
    rows.append((f"{tag}: one process, all cores, Mrays/s", n / s_all / 1e6))
    rows.append((f"{tag}: dask 2 local workers, answers kept on the workers, Mrays/s", n / s_kept / 1e6))
    rows.append((f"{tag}: dask 2 local workers, answers gathered, Mrays/s", n / s_gathered / 1e6))
    rows.append(("dask kept vs one process all cores (throughput ratio)", s_all / s_kept))
    rows.append(("dask gathered vs one process all cores (throughput ratio)", s_all / s_gathered))
    rows.append(("dask: blocks traced per worker, fewest", float(min(traced.values(), default=0))))
    rows.append(("dask: blocks traced per worker, most", float(max(traced.values(), default=0))))
    rows.append(("dask: workers that traced blocks", float(len(traced))))
    rows.append(("dask: tree copies held per worker after the run", float(max(held.values()))))
    rows.append(("dask: workers holding the tree after the run", float(sum(1 for c in held.values() if c))))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--quick", action="store_true", help="100k rays / 100k points, 1 rep: a smoke run"
    )
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument(
        "--only",
        nargs="+",
        choices=("rays", "points", "distance", "dask", "overhead"),
        help="run only these groups of rows (default: all)",
    )
    ap.add_argument("--distance-points", type=int, help="query points per distance row (default 1M)")
    ap.add_argument("--dask-rays", type=int, help="rays of the Dask rows (default 4M)")
    a = ap.parse_args()
    n_rays, n_pts, n_q = (100_000, 100_000, 10_000) if a.quick else (1_000_000, 1_000_000, 100_000)
    reps = 1 if a.quick else a.reps
    rows: list[tuple[str, float]] = []
    only = set(a.only or ("rays", "points", "distance", "dask", "overhead"))
    if "rays" in only:
        rays_rows(rows, n_rays, reps)
    if "points" in only:
        points_rows(rows, n_pts, n_q, reps)
    if "distance" in only:
        distance_rows(rows, a.distance_points or n_pts, reps)
    if "dask" in only:
        dask_rows(rows, a.dask_rays or 4 * n_rays, reps)
    if "overhead" in only:
        overhead_rows(rows, reps)
    width = max(len(r[0]) for r in rows)
    print(f"{'row':<{width}}  value")
    for name, value in rows:
        print(f"{name:<{width}}  {value:.2f}")


if __name__ == "__main__":
    main()
