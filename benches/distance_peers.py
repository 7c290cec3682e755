"""kdray distance against Open3D's RaycastingScene and trimesh, one core.

Usage (pinned, nothing else compiling; the peers' venv from
../shared/anchors/python/setup.sh):

    taskset -c 0 PY benches/distance_peers.py MESH.obj KDRAY [N [RULE]]

KDRAY is the release `kdray` binary. RULE is kdray's sign rule for the
signed distances: `winding` (the default, `--signed --winding`) or
`parity` (`--signed`). N query points (default 1M) uniform in
the mesh's box dilated by 10%, and N within 1% of the box diagonal of the
surface. Timings exclude file I/O (kdray's own "seconds"); each is the best
of two interleaved runs. Sign errors are counted on 5k near points against
an f64 generalized winding number (|w| > 0.5 inside; exact for a closed
mesh), for kdray by RULE and by parity, and for Open3D.
"""

import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import open3d as o3d
import trimesh


def kdray_run(kdray, kdt, pts, out, extra):
    cmd = [kdray, "distance", kdt, pts, "-o", out, "--threads", "1", "--json"] + extra
    r = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return json.loads(r.stdout)["seconds"]


def winding(V, F, q, chunk=64):
    """f64 generalized winding number (Jacobson et al. 2013) of each point."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    w = np.zeros(len(q))
    for s in range(0, len(q), chunk):
        p = q[s : s + chunk, None, :]
        A, B, C = a[None] - p, b[None] - p, c[None] - p
        la, lb, lc = (np.linalg.norm(X, axis=2) for X in (A, B, C))
        det = np.einsum("ijk,ijk->ij", A, np.cross(B, C))
        den = (
            la * lb * lc
            + np.einsum("ijk,ijk->ij", A, B) * lc
            + np.einsum("ijk,ijk->ij", B, C) * la
            + np.einsum("ijk,ijk->ij", C, A) * lb
        )
        w[s : s + chunk] = (2 * np.arctan2(det, den)).sum(axis=1) / (4 * np.pi)
    return w


def main():
    mesh_path, kdray = sys.argv[1], sys.argv[2]
    n = int(sys.argv[3]) if len(sys.argv) > 3 else 1_000_000
    rule = sys.argv[4] if len(sys.argv) > 4 else "winding"
    signed = {"winding": ["--signed", "--winding"], "parity": ["--signed"]}[rule]
    m = trimesh.load(mesh_path, force="mesh", process=False, skip_materials=True)
    V = np.asarray(m.vertices, dtype=np.float32)
    F = np.asarray(m.faces, dtype=np.int64)
    tmp = tempfile.mkdtemp(prefix="kdray-dist-")
    kdt = os.path.join(tmp, "mesh.kdt")
    subprocess.run([kdray, "build", mesh_path, "-o", kdt], check=True, capture_output=True)
    lo, hi = V.min(0), V.max(0)
    ext = hi - lo
    rng = np.random.default_rng(1)
    uniform = (lo - 0.05 * ext + rng.random((n, 3)) * 1.1 * ext).astype(np.float32)
    surf, _ = trimesh.sample.sample_surface(m, n, seed=2)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    near = (surf + d * rng.random((n, 1)) * 0.01 * np.linalg.norm(ext)).astype(np.float32)

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(V), o3d.core.Tensor(F.astype(np.uint32))
    )
    name = os.path.basename(mesh_path)
    for label, q in (("uniform", uniform), ("near", near)):
        pts = os.path.join(tmp, label + ".pts")
        q.tofile(pts)
        out = os.path.join(tmp, label + ".dist")
        qt = o3d.core.Tensor(q)
        o3d_cp, k_cp, o3d_sd, k_sd = [], [], [], []
        for _ in range(2):
            t = time.perf_counter()
            scene.compute_closest_points(qt, nthreads=1)
            o3d_cp.append(time.perf_counter() - t)
            k_cp.append(kdray_run(kdray, kdt, pts, out, []))
            t = time.perf_counter()
            sd = scene.compute_signed_distance(qt, nthreads=1, nsamples=1).numpy()
            o3d_sd.append(time.perf_counter() - t)
            k_sd.append(kdray_run(kdray, kdt, pts, out, signed))
        print(
            f"{name} {label} {n} points: closest point kdray {min(k_cp):.3f} s, "
            f"Open3D {min(o3d_cp):.3f} s ({min(o3d_cp) / min(k_cp):.2f}x); "
            f"signed ({rule}) kdray {min(k_sd):.3f} s, Open3D nsamples=1 {min(o3d_sd):.3f} s "
            f"({min(o3d_sd) / min(k_sd):.2f}x)",
            flush=True,
        )
        try:
            import rtree  # noqa: F401  (trimesh's proximity queries need it)

            sub = q[:20000]
            t = time.perf_counter()
            trimesh.proximity.closest_point(m, sub)
            tm = (time.perf_counter() - t) * n / len(sub)
            print(f"{name} {label}: trimesh {tm:.1f} s est. from 20k ({tm / min(k_cp):.0f}x kdray)", flush=True)
        except ImportError:
            print(f"{name} {label}: trimesh skipped (no rtree module in this venv)", flush=True)
        rec = np.fromfile(out, dtype=[("p", "<f4", 3), ("prim", "<u4"), ("uv", "<f4", 2), ("d", "<f4")])
        if label == "near" and "bunny" in name:
            s = 5000
            w = winding(V.astype(np.float64), F, q[:s].astype(np.float64))
            inside = np.abs(w) > 0.5
            k_in = rec["d"][:s] < 0
            o_in = sd[:s] < 0
            kdray_run(kdray, kdt, pts, out, ["--signed"])
            par = np.fromfile(out, dtype=rec.dtype)
            p_in = par["d"][:s] < 0
            print(
                f"{name} near: sign errors against the f64 winding number on {s} points: "
                f"kdray ({rule}) {int((k_in != inside).sum())}, kdray (parity) {int((p_in != inside).sum())}, "
                f"Open3D {int((o_in != inside).sum())}; "
                f"points with |w| in (0.1, 0.9) (not closed there): {int(((np.abs(w) > 0.1) & (np.abs(w) < 0.9)).sum())}",
                flush=True,
            )


if __name__ == "__main__":
    main()
