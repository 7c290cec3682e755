"""Meshes, rays and points the tests share.

Real meshes come from ``KDRAY_MESHES`` or ``../shared/meshes`` beside the
repository when present (as the Rust tests find them); generated meshes
always run.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import kdray

REPO = Path(__file__).resolve().parents[2]


def shared_meshes() -> Path | None:
    env = os.environ.get("KDRAY_MESHES")
    if env:
        return Path(env)
    d = REPO.parent / "shared" / "meshes"
    return d if d.is_dir() else None


def kdray_cli() -> Path | None:
    """The ``kdray`` command-line tool: ``KDRAY_BIN``, else the repository's newest build."""
    env = os.environ.get("KDRAY_BIN")
    if env:
        return Path(env)
    builds = [REPO / "target" / b / "kdray" for b in ("release", "debug")]
    builds = [p for p in builds if p.is_file()]
    if builds:
        return max(builds, key=lambda p: p.stat().st_mtime)
    found = shutil.which("kdray")
    return Path(found) if found else None


def sphere(rings: int = 24, segments: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """A closed UV sphere of radius 1: vertices (V, 3) float64, triangles (F, 3) int64."""
    theta = np.linspace(0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    ring = np.stack(
        [
            np.outer(np.sin(theta), np.cos(phi)),
            np.outer(np.sin(theta), np.sin(phi)),
            np.outer(np.cos(theta), np.ones_like(phi)),
        ],
        axis=-1,
    ).reshape(-1, 3)
    v = np.vstack([[0, 0, 1], ring, [0, 0, -1]])
    faces = []
    s = segments
    for j in range(s):
        faces.append([0, 1 + j, 1 + (j + 1) % s])
    for i in range(rings - 2):
        for j in range(s):
            a, b = 1 + i * s + j, 1 + i * s + (j + 1) % s
            c, d = a + s, b + s
            faces += [[a, c, b], [b, c, d]]
    last = len(v) - 1
    base = 1 + (rings - 2) * s
    for j in range(s):
        faces.append([base + j, last, base + (j + 1) % s])
    return v, np.array(faces, dtype=np.int64)


def soup(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` random triangles in the unit cube (overlapping, every size)."""
    rng = np.random.default_rng(seed)
    centres = rng.random((n, 1, 3))
    size = rng.random((n, 1, 1)) ** 3 * 0.3
    v = (centres + (rng.random((n, 3, 3)) - 0.5) * size).reshape(-1, 3)
    return v, np.arange(3 * n).reshape(n, 3)


def random_rays(n: int, lo: np.ndarray, hi: np.ndarray, seed: int) -> np.ndarray:
    """``n`` rays ``(n, 6)`` float32 from points in the box, every which way."""
    rng = np.random.default_rng(seed)
    o = lo + (hi - lo) * rng.random((n, 3))
    d = rng.normal(size=(n, 3))
    return np.hstack([o, d]).astype(np.float32)


def camera_rays(w: int, h: int, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """A pinhole camera's rays ``(h, w, 6)`` looking at the box from its -z side."""
    c = (lo + hi) / 2
    ext = float(np.max(hi - lo))
    eye = c - np.array([0, 0, 1.5 * ext])
    ys, xs = np.meshgrid(np.linspace(-0.5, 0.5, h), np.linspace(-0.5, 0.5, w), indexing="ij")
    d = np.stack([xs * 0.8, ys * 0.8, np.ones_like(xs)], axis=-1)
    o = np.broadcast_to(eye, d.shape)
    return np.concatenate([o, d], axis=-1).astype(np.float32)


MESHES = {
    "sphere": lambda: sphere(),
    "soup": lambda: soup(3000, 7),
}


@pytest.fixture(scope="session", params=sorted(MESHES))
def mesh(request: pytest.FixtureRequest) -> tuple[np.ndarray, np.ndarray]:
    return MESHES[request.param]()


@pytest.fixture(scope="session")
def sphere_tree() -> kdray.TriangleTree:
    v, f = sphere()
    return kdray.TriangleTree(v, f)


SHARED = ["cornell-box.obj", "suzanne.obj", "teapot.obj", "stanford-bunny.obj"]


@pytest.fixture(scope="session", params=SHARED)
def shared_mesh(request: pytest.FixtureRequest) -> Path:
    d = shared_meshes()
    if d is None or not (d / request.param).is_file():
        pytest.skip(f"{request.param}: no shared meshes (set KDRAY_MESHES=DIR)")
    return d / request.param
