"""kdray over Dask: ray casting, distance and k-nearest queries on arrays chunked by rows.

Install with ``pip install "kdray[dask]"``. The tree goes to each worker
once: with a ``distributed`` client active, it is scattered with
``broadcast=True`` and every block's task refers to that copy; without
one (the local schedulers) the tasks share the caller's tree. Each block
is answered by the tree's own call, so the results equal the one-process
call bit for bit.

    from dask.distributed import Client, LocalCluster
    import dask.array as da
    import kdray, kdray.dask

    client = Client(LocalCluster(n_workers=2, threads_per_worker=1))
    tree = kdray.TriangleTree.from_file("bunny.obj")
    rays = da.from_array(rays_np, chunks=(1_000_000, 6))
    hits = kdray.dask.cast_rays(tree, rays)      # dict of dask arrays
    t_hit = hits["t_hit"].compute()
"""

from __future__ import annotations

from typing import Any

import dask.array as da
import numpy as np

from . import KDTree, Scene, TriangleTree, _inside_rule

__all__ = [
    "cast_rays",
    "compute_closest_points",
    "compute_distance",
    "compute_occupancy",
    "compute_signed_distance",
    "query",
    "scatter",
]

# A block of `cast_rays` (or `compute_closest_points`) answers, one record
# a row: every field computed once per block, the dask arrays returned are
# views of it.
_HIT = np.dtype(
    [
        ("t_hit", np.float32),
        ("primitive_ids", np.uint32),
        ("primitive_uvs", np.float32, (2,)),
        ("primitive_normals", np.float32, (3,)),
    ]
)
_CLOSEST = np.dtype(
    [
        ("points", np.float32, (3,)),
        ("primitive_ids", np.uint32),
        ("primitive_uvs", np.float32, (2,)),
        ("primitive_normals", np.float32, (3,)),
    ]
)
_SCENE_CLOSEST = np.dtype(
    [
        ("points", np.float32, (3,)),
        ("geometry_ids", np.uint32),
        ("primitive_ids", np.uint32),
        ("primitive_uvs", np.float32, (2,)),
        ("primitive_normals", np.float32, (3,)),
    ]
)
_SCENE_HIT = np.dtype(
    [
        ("t_hit", np.float32),
        ("geometry_ids", np.uint32),
        ("primitive_ids", np.uint32),
        ("primitive_uvs", np.float32, (2,)),
        ("primitive_normals", np.float32, (3,)),
    ]
)


def scatter(tree: Any) -> Any:
    """``tree`` as the block tasks should take it.

    With a ``distributed`` client active, a future of the tree scattered to
    every worker (``client.scatter(tree, broadcast=True)``): it crosses the
    wire once per worker. Otherwise the tree itself.
    """
    try:
        from distributed import get_client
    except ImportError:
        return tree
    try:
        client = get_client()
    except ValueError:
        return tree
    return client.scatter(tree, broadcast=True, hash=False)  # type: ignore[no-untyped-call]


def _rows(x: Any, width: int, name: str) -> Any:
    """``x`` as a 2-D dask array of ``width`` columns in one chunk."""
    arr = da.asarray(x)  # type: ignore[no-untyped-call]
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(f"{name}: expected a 2-D dask array of shape (N, {width}), got {arr.shape}")
    if len(arr.chunks[1]) != 1:
        arr = arr.rechunk({1: width})
    return arr


def _records_block(
    block: np.ndarray, tree: Any, method: str, args: tuple[Any, ...], dtype: np.dtype[Any]
) -> np.ndarray:
    """``tree.<method>(block, *args)``'s dict of arrays as one record array."""
    got = getattr(tree, method)(block, *args)
    out = np.empty(block.shape[0], dtype=dtype)
    for name in dtype.names or ():
        out[name] = got[name]
    return out


def _by_records(
    rows: Any, tree: Any, method: str, args: tuple[Any, ...], dtype: np.dtype[Any]
) -> dict[str, Any]:
    """A call returning a dict of arrays, block by block: the dict's names as dask arrays.

    Each block is answered once, as records; the returned arrays are its fields.
    """
    records = rows.map_blocks(
        _records_block,
        scatter(tree),
        method,
        args,
        dtype,
        drop_axis=1,
        dtype=dtype,
        meta=np.empty((0,), dtype=dtype),
    )
    out: dict[str, Any] = {}
    for name in dtype.names or ():
        field = dtype.fields[name][0] if dtype.fields else None
        assert field is not None
        tail = field.shape
        if tail:
            out[name] = records.map_blocks(
                _field,
                name,
                new_axis=1,
                chunks=(records.chunks[0], tail),
                dtype=field.base,
                meta=np.empty((0,) + tail, dtype=field.base),
            )
        else:
            out[name] = records.map_blocks(_field, name, dtype=field, meta=np.empty((0,), field))
    return out


def _row_block(block: np.ndarray, tree: Any, method: str, args: tuple[Any, ...]) -> np.ndarray:
    return getattr(tree, method)(block, *args)  # type: ignore[no-any-return]


def _by_row(rows: Any, tree: Any, method: str, args: tuple[Any, ...], dtype: Any) -> Any:
    """A call returning one value a row, block by block: a 1-D dask array."""
    return rows.map_blocks(
        _row_block,
        scatter(tree),
        method,
        args,
        drop_axis=1,
        dtype=dtype,
        meta=np.empty((0,), dtype=dtype),
    )


def cast_rays(tree: TriangleTree | Scene, rays: Any, nthreads: int = 0) -> dict[str, Any]:
    """``tree.cast_rays`` over a dask array ``(N, 6)`` chunked by rows.

    Returns the same names as the direct call, as dask arrays chunked as
    ``rays``; compute them together (``dask.compute(*d.values())``) to
    trace each block once.
    """
    if not isinstance(tree, (TriangleTree, Scene)):
        raise TypeError(f"tree: expected a kdray.TriangleTree or kdray.Scene, got {type(tree)}")
    dtype = _SCENE_HIT if isinstance(tree, Scene) else _HIT
    return _by_records(_rows(rays, 6, "rays"), tree, "cast_rays", (nthreads,), dtype)


def _points(tree: Any, query_points: Any, scene: bool = True) -> Any:
    """The query points' dask array, for a tree (and, where ``scene``, a scene) that answers them."""
    if not isinstance(tree, (TriangleTree, Scene) if scene else TriangleTree):
        want = "a kdray.TriangleTree or kdray.Scene" if scene else "a kdray.TriangleTree"
        raise TypeError(f"tree: expected {want}, got {type(tree)}")
    return _rows(query_points, 3, "query_points")


def compute_closest_points(
    tree: TriangleTree | Scene, query_points: Any, nthreads: int = 0
) -> dict[str, Any]:
    """``tree.compute_closest_points`` over a dask array ``(N, 3)`` chunked by rows.

    Returns the same names as the direct call (with ``geometry_ids`` for
    a :class:`~kdray.Scene`), as dask arrays chunked as
    ``query_points``; compute them together to answer each block once.
    """
    q = _points(tree, query_points)
    dtype = _SCENE_CLOSEST if isinstance(tree, Scene) else _CLOSEST
    return _by_records(q, tree, "compute_closest_points", (nthreads,), dtype)


def compute_distance(tree: TriangleTree | Scene, query_points: Any, nthreads: int = 0) -> Any:
    """``tree.compute_distance`` over a dask array ``(N, 3)`` chunked by rows: ``(N,)`` float32."""
    return _by_row(_points(tree, query_points), tree, "compute_distance", (nthreads,), np.float32)


def _inside(
    method: str, tree: TriangleTree, query_points: Any, nthreads: int, nsamples: int, winding: bool
) -> Any:
    """A call that takes ``nsamples`` and ``winding`` (the inside rule), checked before any block runs."""
    q = _points(tree, query_points, scene=False)
    return _by_row(q, tree, method, (nthreads, *_inside_rule(nsamples, winding)), np.float32)


def compute_signed_distance(
    tree: TriangleTree, query_points: Any, nthreads: int = 0, nsamples: int = 1, winding: bool = False
) -> Any:
    """``tree.compute_signed_distance`` over a dask array ``(N, 3)`` chunked by rows: ``(N,)`` float32."""
    return _inside("compute_signed_distance", tree, query_points, nthreads, nsamples, winding)


def compute_occupancy(
    tree: TriangleTree, query_points: Any, nthreads: int = 0, nsamples: int = 1, winding: bool = False
) -> Any:
    """``tree.compute_occupancy`` over a dask array ``(N, 3)`` chunked by rows: ``(N,)`` float32 0 or 1."""
    return _inside("compute_occupancy", tree, query_points, nthreads, nsamples, winding)


def _field(block: np.ndarray, name: str) -> np.ndarray:
    return np.ascontiguousarray(block[name])


def _query_block(
    block: np.ndarray, tree: KDTree, k: int, ub: float, workers: int, dtype: np.dtype[Any]
) -> np.ndarray:
    d, i = tree.query(block, k=k, distance_upper_bound=ub, workers=workers)
    out = np.empty(block.shape[0], dtype=dtype)
    out["d"] = d.reshape(block.shape[0], k)
    out["i"] = i.reshape(block.shape[0], k)
    return out


def query(
    tree: KDTree,
    x: Any,
    k: int = 1,
    distance_upper_bound: float = np.inf,
    workers: int = -1,
) -> tuple[Any, Any]:
    """``tree.query(x, k)`` over a dask array ``(M, m)`` chunked by rows.

    ``workers``: threads per block (-1: all cores of the machine running
    it). Returns ``(d, i)`` as dask arrays shaped as scipy's (``(M,)`` for
    ``k=1``, else ``(M, k)``), equal to the direct call.
    """
    if not isinstance(tree, KDTree):
        raise TypeError(f"tree: expected a kdray.KDTree, got {type(tree)}")
    if not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be an int of at least 1, not {k!r}")
    k = int(k)
    q = _rows(x, tree.m, "x")
    dtype = np.dtype([("d", tree.dtype, (k,)), ("i", np.int64, (k,))])
    records = q.map_blocks(
        _query_block,
        scatter(tree),
        k,
        float(distance_upper_bound),
        workers,
        dtype,
        drop_axis=1,
        dtype=dtype,
        meta=np.empty((0,), dtype=dtype),
    )
    parts = []
    for name, base in (("d", tree.dtype), ("i", np.dtype(np.int64))):
        if k == 1:
            parts.append(
                records.map_blocks(_column, name, dtype=base, meta=np.empty((0,), base))
            )
        else:
            parts.append(
                records.map_blocks(
                    _field,
                    name,
                    new_axis=1,
                    chunks=(records.chunks[0], (k,)),
                    dtype=base,
                    meta=np.empty((0, k), dtype=base),
                )
            )
    return parts[0], parts[1]


def _column(block: np.ndarray, name: str) -> np.ndarray:
    return np.ascontiguousarray(block[name][:, 0])
