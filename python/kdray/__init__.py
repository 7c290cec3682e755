"""kdray: exact k-d tree ray casting and nearest-neighbour search over numpy arrays.

- :class:`TriangleTree`: a triangle mesh's k-d tree; ``cast_rays``,
  ``test_occlusions``, ``count_intersections`` and ``list_intersections``,
  ``compute_closest_points``, ``compute_distance``,
  ``compute_signed_distance`` and ``compute_occupancy`` with Open3D's
  ``RaycastingScene`` names and conventions.
- :class:`Scene`: a scene blob of instanced meshes (``kdray build
  --instances``) with the same calls and ``geometry_ids``.
- :class:`KDTree`: a point k-d tree with ``scipy.spatial.KDTree``'s
  ``query`` and ``query_ball_point``.

Every answer is exact: the closest hit is the one testing every triangle
finds (smallest ``t``; at equal ``t`` the lower triangle index), the
nearest neighbours those a brute-force scan finds (equal distance: the
lower index first). Batches run on all cores with the GIL released. Trees
pickle as their blob, validated when they come back.
"""

from __future__ import annotations

import operator
import os
import pickle
from collections.abc import Sequence
from typing import Any, Self

import numpy as np
import numpy.typing as npt

from . import _kdray
from ._kdray import MAX_COORD, MAX_DIM, BlobError

__all__ = [
    "MAX_COORD",
    "MAX_DIM",
    "MISS",
    "BlobError",
    "KDTree",
    "Scene",
    "TriangleTree",
]

#: ``primitive_ids`` / ``geometry_ids`` of a ray that hits nothing (Open3D's
#: ``RaycastingScene.INVALID_ID``).
MISS = 0xFFFFFFFF

_F32 = np.dtype(np.float32)

_NO_SCENE_SIGN = (
    "signed distance and occupancy are not offered on a Scene: each crossing of the "
    "sign's ray is not yet counted once per instance; build a TriangleTree from the "
    "scene's mesh file (TriangleTree.from_file) to sign"
)


# --- argument checks -------------------------------------------------------


def _array(a: Any, name: str) -> np.ndarray:
    """``a`` as a numeric numpy array (never written), or a clear error."""
    try:
        arr = np.asarray(a)
    except (ValueError, TypeError) as e:  # ragged lists and the like
        raise ValueError(f"{name}: not an array of numbers: {e}") from None
    if arr.dtype.kind not in "fiu":
        raise ValueError(f"{name}: expected a float or integer array, got dtype {arr.dtype}")
    return arr


def _finite_rows(arr: np.ndarray, name: str) -> None:
    """Raise naming the first row of ``arr`` (2-D) with a NaN or infinity."""
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        row = int(np.argmax(bad))
        raise ValueError(f"{name}: row {row} has a non-finite coordinate: {arr[row].tolist()}")


def _options(
    builder: str,
    max_depth: int | None,
    traversal_cost: float | None,
    intersection_cost: float | None,
    empty_bonus: float | None,
    threads: int | None,
) -> dict[str, Any]:
    if max_depth is not None and not 0 <= max_depth <= 2**32 - 1:
        raise ValueError(f"max_depth must be a non-negative integer, not {max_depth}")
    if threads is not None and threads < 0:
        raise ValueError(f"threads must be 0 (all cores) or more, not {threads}")
    return {
        "builder": builder,
        "max_depth": max_depth,
        "traversal_cost": traversal_cost,
        "intersection_cost": intersection_cost,
        "empty_bonus": empty_bonus,
        "threads": threads,
    }


def _whole(value: Any, name: str) -> int:
    """``value`` as an int that fits the extension's 64-bit counts, or an
    error naming ``name`` (not a truncated float, not an ``OverflowError``
    from inside the extension)."""
    try:
        n = operator.index(value)
    except TypeError:
        raise TypeError(f"{name} must be an integer, not {value!r}") from None
    if n >= 2**63:
        raise ValueError(f"{name} {n} is more than any machine's threads")
    return n


def _nthreads(nthreads: int) -> int:
    n = _whole(nthreads, "nthreads")
    if n < 0:
        raise ValueError(f"nthreads must be 0 (all cores) or more, not {nthreads}")
    return n


def _nsamples(nsamples: int) -> int:
    """Open3D's ``nsamples``: an odd number of rays from 1 to 7."""
    ok = isinstance(nsamples, (int, np.integer)) and not isinstance(nsamples, (bool, np.bool_))
    if not (ok and 1 <= nsamples <= 7 and nsamples % 2 == 1):
        raise ValueError(f"nsamples must be an odd number from 1 to 7, not {nsamples!r}")
    return int(nsamples)


def _inside_rule(nsamples: int, winding: bool) -> tuple[int, bool]:
    """``nsamples`` and ``winding`` checked together: the winding number takes no rays."""
    n = _nsamples(nsamples)
    if winding and n != 1:
        raise ValueError(f"winding=True decides by the winding number, not by rays: nsamples must be 1, not {n}")
    return n, bool(winding)


def _rays(
    rays: Any,
    origins: Any,
    directions: Any,
    tnear: Any,
    tfar: Any,
) -> tuple[np.ndarray, tuple[int, ...]]:
    """The rays in the kernel's ``(N, 8)`` float32 layout and their leading shape."""
    if rays is not None:
        if origins is not None or directions is not None:
            raise ValueError("give either rays or origins and directions, not both")
        r = _array(rays, "rays")
        if r.ndim < 1 or r.shape[-1] != 6:
            raise ValueError(f"rays: expected shape (..., 6), got {r.shape}")
        lead = r.shape[:-1]
        o, d = r[..., 0:3], r[..., 3:6]
    else:
        if origins is None or directions is None:
            raise ValueError("give rays (..., 6), or both origins and directions (..., 3)")
        o, d = _array(origins, "origins"), _array(directions, "directions")
        for name, a in (("origins", o), ("directions", d)):
            if a.ndim < 1 or a.shape[-1] != 3:
                raise ValueError(f"{name}: expected shape (..., 3), got {a.shape}")
        if o.shape != d.shape:
            raise ValueError(f"origins {o.shape} and directions {d.shape} differ in shape")
        lead = o.shape[:-1]
    out = np.empty(lead + (8,), dtype=_F32)
    if o.dtype == _F32 and d.dtype == _F32:
        out[..., 0:3] = o
        out[..., 4:7] = d
    else:
        with np.errstate(over="ignore", invalid="ignore"):  # beyond float32: inf, a miss
            out[..., 0:3] = o
            out[..., 4:7] = d
    for col, name, v in ((3, "tnear", tnear), (7, "tfar", tfar)):
        if type(v) is float:  # the defaults, and most calls: no array to make
            out[..., col] = v
            continue
        a = _array(v, name)
        try:
            out[..., col] = a
        except ValueError:
            raise ValueError(
                f"{name}: shape {a.shape} does not broadcast to the rays' {lead}"
            ) from None
    return out.reshape(-1, 8), lead


def _points(query_points: Any) -> tuple[np.ndarray, tuple[int, ...]]:
    """The query points as a C-contiguous ``(N, 3)`` float32 array and their leading shape."""
    q = _array(query_points, "query_points")
    if q.ndim < 1 or q.shape[-1] != 3:
        raise ValueError(f"query_points: expected shape (..., 3), got {q.shape}")
    if q.dtype == _F32:
        return np.ascontiguousarray(q.reshape(-1, 3)), q.shape[:-1]
    with np.errstate(over="ignore"):  # beyond float32: inf, a NaN distance
        return np.ascontiguousarray(q.reshape(-1, 3), dtype=_F32), q.shape[:-1]


def _ray_splits(splits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Open3D's ``ray_splits`` and ``ray_ids`` of a hit list's ``splits``."""
    starts = splits.astype(np.int64)
    counts = starts[1:] - starts[:-1]
    ray_ids = np.repeat(np.arange(len(counts), dtype=np.uint32), counts)
    return starts, ray_ids


def _reduce(obj: Any, protocol: int, rebuild: Any) -> tuple[Any, tuple[Any, ...]]:
    """Pickle as the blob: out of band under protocol 5 where the pickler takes it."""
    blob = obj.to_bytes()
    if protocol >= 5:
        return rebuild, (pickle.PickleBuffer(blob),)
    return rebuild, (blob,)


# --- triangles -------------------------------------------------------------


class _Blob:
    """What every tree shares: it is its blob, held by the compiled object ``_tree``."""

    __slots__ = ()
    _tree: Any

    @classmethod
    def _wrap(cls, tree: Any) -> Self:
        self = cls.__new__(cls)
        self._tree = tree
        return self

    def to_bytes(self) -> bytes:
        """The blob (the bytes ``kdray build`` writes), without a copy where it is held as ``bytes``."""
        return self._tree.to_bytes()  # type: ignore[no-any-return]

    def save(self, path: str | os.PathLike[str]) -> None:
        """Writes the blob to ``path`` (a temporary file renamed into place), as ``kdray build`` does."""
        self._tree.save(os.fspath(path))


class _RayQueries(_Blob):
    """The ray calls ``TriangleTree`` and ``Scene`` share."""

    __slots__ = ()
    _tree: Any
    _geometry = False

    def _cast(self, rays: np.ndarray, nthreads: int, packet: int | None) -> tuple[Any, ...]:
        raise NotImplementedError

    def cast_rays(
        self,
        rays: npt.ArrayLike | None = None,
        nthreads: int = 0,
        *,
        origins: npt.ArrayLike | None = None,
        directions: npt.ArrayLike | None = None,
        tnear: npt.ArrayLike = 0.0,
        tfar: npt.ArrayLike = np.inf,
        packet: int | None = None,
    ) -> dict[str, np.ndarray]:
        """The closest hit of each ray, with Open3D's result names.

        ``rays`` is ``(..., 6)``: origin then direction (any float dtype;
        traced in float32), over ``[tnear, tfar]``. Or give ``origins`` and
        ``directions`` (``(..., 3)`` each); ``tnear`` / ``tfar`` broadcast
        to the leading shape. ``nthreads``: 0 for all cores. ``packet``:
        ``None`` (each block of 256 rays takes the walk timed cheapest on
        the batch: packets or single rays where origins lie close
        together, single rays or rays in turns where they lie far apart),
        or 1, 4, 8 or 16 consecutive rays traced together; the answers are
        the same for any width.

        Returns ``t_hit`` (float32, inf on a miss), ``primitive_ids``
        (uint32, :data:`MISS` on a miss), ``primitive_uvs`` (``(..., 2)``,
        the barycentric weights of vertices 1 and 2; zero on a miss) and
        ``primitive_normals`` (``(..., 3)``, the hit triangle's unit
        geometric normal ``(v1 - v0) x (v2 - v0)``; zero on a miss), each
        of the rays' leading shape. Rays with a NaN or infinite origin, a
        zero or non-finite direction or an empty range miss.
        """
        r, lead = _rays(rays, origins, directions, tnear, tfar)
        out = self._cast(r, _nthreads(nthreads), packet)
        names = ["t_hit", "primitive_ids", "primitive_uvs", "primitive_normals"]
        if self._geometry:
            names.insert(1, "geometry_ids")
        tails: dict[str, tuple[int, ...]] = {"primitive_uvs": (2,), "primitive_normals": (3,)}
        return {n: a.reshape(lead + tails.get(n, ())) for n, a in zip(names, out)}

    def test_occlusions(
        self,
        rays: npt.ArrayLike,
        tnear: npt.ArrayLike = 0.0,
        tfar: npt.ArrayLike = np.inf,
        nthreads: int = 0,
        *,
        packet: int | None = None,
    ) -> np.ndarray:
        """Whether each ray ``(..., 6)`` hits anything in ``[tnear, tfar]``: bool, of its leading shape."""
        r, lead = _rays(rays, None, None, tnear, tfar)
        return self._occluded(r, _nthreads(nthreads), packet).reshape(lead)

    def _occluded(self, rays: np.ndarray, nthreads: int, packet: int | None) -> np.ndarray:
        raise NotImplementedError

    def count_intersections(self, rays: npt.ArrayLike, nthreads: int = 0) -> np.ndarray:
        """How many triangles each ray ``(..., 6)`` crosses (each once): int32, of its leading shape."""
        r, lead = _rays(rays, None, None, 0.0, np.inf)
        splits = self._tree.hits(r, _nthreads(nthreads))[0]
        return np.diff(splits).astype(np.int32).reshape(lead)  # type: ignore[no-any-return]

    def list_intersections(self, rays: npt.ArrayLike, nthreads: int = 0) -> dict[str, np.ndarray]:
        """Every hit of every ray, in Open3D's CSR form.

        Rays ``(..., 6)`` are numbered in C order. Returns ``ray_splits``
        (int64, ``N + 1``: ray ``i``'s hits are ``ray_splits[i]:ray_splits[i + 1]``),
        ``ray_ids`` (uint32), ``t_hit``, ``primitive_ids`` and
        ``primitive_uvs`` (``(H, 2)``), each ray's hits by ``t`` then
        triangle index, each triangle once (``geometry_ids`` too for a
        :class:`Scene`, whose hits at one ``t`` go by instance then triangle).
        """
        r, _ = _rays(rays, None, None, 0.0, np.inf)
        out = self._tree.hits(r, _nthreads(nthreads))
        ray_splits, ray_ids = _ray_splits(out[0])
        result = {"ray_splits": ray_splits, "ray_ids": ray_ids, "t_hit": out[1]}
        if self._geometry:
            result["geometry_ids"] = out[2]
        result["primitive_ids"] = out[-2]
        result["primitive_uvs"] = out[-1]
        return result



class TriangleTree(_RayQueries):
    """A triangle mesh's k-d tree, for exact ray casting and distance queries.

    Build from ``vertices`` ``(V, 3)`` (any float or integer dtype; stored
    as float32) and ``triangles`` ``(F, 3)`` (integer indices into
    ``vertices``), or with :meth:`from_file`, :meth:`from_bytes` or
    :meth:`load`. Builder options, as ``kdray build`` takes them:
    ``builder`` (``"sah"``, ``"sweep"``, ``"binned"``, ``"fast"``,
    ``"median"`` or ``"middle"``), ``max_depth``, ``traversal_cost``,
    ``intersection_cost``, ``empty_bonus`` and ``threads`` (0 or None: all
    cores; the tree is the same for any count). ``primitive_ids`` are
    rows of ``triangles``.
    """

    __slots__ = ("_tree",)

    def __init__(
        self,
        vertices: npt.ArrayLike,
        triangles: npt.ArrayLike,
        *,
        builder: str = "sah",
        max_depth: int | None = None,
        traversal_cost: float | None = None,
        intersection_cost: float | None = None,
        empty_bonus: float | None = None,
        threads: int | None = None,
    ) -> None:
        v = _array(vertices, "vertices")
        if v.ndim != 2 or v.shape[1] != 3:
            raise ValueError(f"vertices: expected shape (V, 3), got {v.shape}")
        f = _array(triangles, "triangles")
        if f.dtype.kind not in "iu":
            raise ValueError(f"triangles: expected integer vertex indices, got dtype {f.dtype}")
        if f.ndim != 2 or f.shape[1] != 3:
            raise ValueError(f"triangles: expected shape (F, 3), got {f.shape}")
        if f.shape[0] == 0:
            raise ValueError("triangles: no triangles")
        with np.errstate(over="ignore"):  # beyond float32: inf, refused below
            v32 = v.astype(_F32, copy=False)
        _finite_rows(v32, "vertices (as float32)")
        lo, hi = int(f.min()), int(f.max())
        if lo < 0 or hi >= v.shape[0]:
            bad = int(np.argmax(((f < 0) | (f >= v.shape[0])).any(axis=1)))
            raise ValueError(
                f"triangles: row {bad} {f[bad].tolist()} indexes outside the "
                f"{v.shape[0]} vertices"
            )
        tris = np.ascontiguousarray(v32[f])
        opts = _options(builder, max_depth, traversal_cost, intersection_cost, empty_bonus, threads)
        self._tree = _kdray.TriangleTree.build(tris, opts)

    @classmethod
    def from_file(
        cls,
        path: str | os.PathLike[str],
        *,
        builder: str = "sah",
        max_depth: int | None = None,
        traversal_cost: float | None = None,
        intersection_cost: float | None = None,
        empty_bonus: float | None = None,
        threads: int | None = None,
    ) -> TriangleTree:
        """Loads a mesh file (``.obj``, ``.ply``, ``.gltf``, ``.glb``; glTF nodes flattened) and builds its tree."""
        opts = _options(builder, max_depth, traversal_cost, intersection_cost, empty_bonus, threads)
        return cls._wrap(_kdray.TriangleTree.from_mesh_file(os.fspath(path), opts))

    @classmethod
    def from_bytes(cls, buffer: Any, *, copy: bool = False) -> TriangleTree:
        """A tree from its blob (``bytes``, ``memoryview``, ``mmap``, anything exporting bytes).

        The blob is validated in full (:class:`BlobError` names the first
        problem). A read-only, contiguous, 4-byte aligned buffer is read in
        place (no copy; keep its memory unchanged while the tree lives);
        any other, or any with ``copy=True``, is copied once.
        """
        return cls._wrap(_kdray.TriangleTree.from_buffer(buffer, copy))

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> TriangleTree:
        """Reads and validates a ``.kdt`` blob file (``kdray build``'s output)."""
        return cls._wrap(_kdray.TriangleTree.load(os.fspath(path)))

    @property
    def triangles(self) -> np.ndarray:
        """The triangles' vertices, ``(F, 3, 3)`` float32, in mesh order (a copy)."""
        return self._tree.triangles()  # type: ignore[no-any-return]

    @property
    def triangle_count(self) -> int:
        """How many triangles."""
        return self._tree.triangle_count  # type: ignore[no-any-return]

    @property
    def node_count(self) -> int:
        """How many tree nodes."""
        return self._tree.node_count  # type: ignore[no-any-return]

    @property
    def depth(self) -> int:
        """The depth of the deepest node."""
        return self._tree.depth  # type: ignore[no-any-return]

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The root cell's ``(min, max)`` corners."""
        lo, hi = self._tree.bounds
        return np.array(lo, dtype=_F32), np.array(hi, dtype=_F32)

    def _cast(self, rays: np.ndarray, nthreads: int, packet: int | None) -> tuple[Any, ...]:
        return self._tree.cast(rays, nthreads, packet)  # type: ignore[no-any-return]

    def _occluded(self, rays: np.ndarray, nthreads: int, packet: int | None) -> np.ndarray:
        return self._tree.occluded(rays, nthreads, packet)  # type: ignore[no-any-return]

    def compute_closest_points(
        self, query_points: npt.ArrayLike, nthreads: int = 0
    ) -> dict[str, np.ndarray]:
        """The closest point on the mesh to each query, with Open3D's names.

        ``query_points`` is ``(..., 3)`` (any float dtype; answered in
        float32). Returns ``points`` (float32 ``(..., 3)``),
        ``primitive_ids`` (uint32, the triangle; at equal distance the
        lower index), ``primitive_uvs`` (``(..., 2)``, the barycentric
        weights of vertices 1 and 2 at the point) and ``primitive_normals``
        (``(..., 3)``, the triangle's unit normal as :meth:`cast_rays`
        gives it). A query with a NaN or infinite coordinate has no
        closest point: NaN ``points`` and ``primitive_uvs``, :data:`MISS`,
        a zero normal. Exact: the answer of testing every triangle, bit
        for bit. ``nthreads``: 0 for all cores.
        """
        q, lead = _points(query_points)
        out = self._tree.closest_points(q, _nthreads(nthreads))
        names = ("points", "primitive_ids", "primitive_uvs", "primitive_normals")
        tails = ((3,), (), (2,), (3,))
        return {n: a.reshape(lead + t) for n, a, t in zip(names, out, tails)}

    def compute_distance(self, query_points: npt.ArrayLike, nthreads: int = 0) -> np.ndarray:
        """The distance from each query ``(..., 3)`` to the mesh: float32, of the leading shape.

        The square root of the exact closest point's squared distance
        (computed in float64), rounded once; NaN for a query with a NaN or
        infinite coordinate.
        """
        q, lead = _points(query_points)
        return self._tree.distances(q, _nthreads(nthreads)).reshape(lead)  # type: ignore[no-any-return]

    def compute_signed_distance(
        self, query_points: npt.ArrayLike, nthreads: int = 0, nsamples: int = 1, winding: bool = False
    ) -> np.ndarray:
        """:meth:`compute_distance`, negative inside the mesh: float32, of the leading shape.

        Inside is decided as :meth:`compute_occupancy` decides it. A point
        on the surface (distance 0) may get either sign.
        """
        q, lead = _points(query_points)
        n, w = _inside_rule(nsamples, winding)
        return self._tree.signed_distances(q, _nthreads(nthreads), n, w).reshape(lead)  # type: ignore[no-any-return]

    def compute_occupancy(
        self, query_points: npt.ArrayLike, nthreads: int = 0, nsamples: int = 1, winding: bool = False
    ) -> np.ndarray:
        """Whether each query ``(..., 3)`` is inside the mesh: float32 1 or 0 (Open3D's), of the leading shape.

        ``nsamples=1``: the parity of the crossings of one ray from the
        point (closed meshes; a ray through an edge or a vertex is counted
        once). ``nsamples`` 3, 5 or 7: the majority of that many rays in
        fixed directions, each by parity (for open or self-intersecting
        meshes). ``winding=True`` (kdray's, with ``nsamples=1``): the
        generalized winding number above one half in magnitude, the mesh's
        holes closed by small caps (open meshes with consistently oriented
        triangles; docs/distance.md). A point outside the tree's bounds, or
        with a NaN or infinite coordinate, is outside.
        """
        q, lead = _points(query_points)
        n, w = _inside_rule(nsamples, winding)
        inside = self._tree.occupancy(q, _nthreads(nthreads), n, w)
        return inside.astype(_F32).reshape(lead)  # type: ignore[no-any-return]

    def __reduce_ex__(self, protocol: Any) -> tuple[Any, tuple[Any, ...]]:
        return _reduce(self, int(protocol), _triangle_tree)

    def __repr__(self) -> str:
        return f"kdray.TriangleTree({self.triangle_count} triangles, {self.node_count} nodes)"


class Scene(_RayQueries):
    """A scene of instanced meshes: the blob ``kdray build --instances`` writes.

    The ray calls are :class:`TriangleTree`'s; each hit also names its
    instance (``geometry_ids``, :data:`MISS` on a miss), and
    ``primitive_ids`` index that instance's mesh. Normals are in world space.
    """

    __slots__ = ("_tree",)
    _geometry = True

    def __init__(self) -> None:
        raise TypeError("open a scene with Scene.load(path) or Scene.from_bytes(buffer)")

    @classmethod
    def from_bytes(cls, buffer: Any, *, copy: bool = False) -> Scene:
        """A scene from its blob, validated (read in place when read-only and 64-byte aligned)."""
        return cls._wrap(_kdray.Scene.from_buffer(buffer, copy))

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Scene:
        """Reads and validates a scene blob file."""
        return cls._wrap(_kdray.Scene.load(os.fspath(path)))

    @property
    def instance_count(self) -> int:
        """How many instances."""
        return self._tree.instance_count  # type: ignore[no-any-return]

    @property
    def mesh_count(self) -> int:
        """How many meshes the instances place."""
        return self._tree.mesh_count  # type: ignore[no-any-return]

    def _cast(self, rays: np.ndarray, nthreads: int, packet: int | None) -> tuple[Any, ...]:
        if packet not in (None, 1, 4, 8, 16):
            raise ValueError(f"packet must be None, 1, 4, 8 or 16, not {packet}")
        return self._tree.cast(rays, nthreads)  # type: ignore[no-any-return]

    def _occluded(self, rays: np.ndarray, nthreads: int, packet: int | None) -> np.ndarray:
        if packet not in (None, 1, 4, 8, 16):
            raise ValueError(f"packet must be None, 1, 4, 8 or 16, not {packet}")
        return self._tree.occluded(rays, nthreads)  # type: ignore[no-any-return]

    def compute_closest_points(
        self, query_points: npt.ArrayLike, nthreads: int = 0
    ) -> dict[str, np.ndarray]:
        """The closest point on any instance to each query, as :meth:`TriangleTree.compute_closest_points`.

        Returns ``points`` (world space), ``geometry_ids`` (uint32, the
        instance; :data:`MISS` for none), ``primitive_ids`` (the triangle
        in that instance's mesh), ``primitive_uvs`` and
        ``primitive_normals`` (world space), each of the queries' leading
        shape. Distances are measured in world space: at equal distance
        the lower instance, then the lower triangle, bit for bit the answer
        of testing every instance's every triangle. An instance scaled
        unevenly or sheared makes the call raise ``ValueError`` naming it
        (its nearest point in mesh space is not the nearest in the world).
        """
        q, lead = _points(query_points)
        out = self._tree.closest_points(q, _nthreads(nthreads))
        names = ("points", "geometry_ids", "primitive_ids", "primitive_uvs", "primitive_normals")
        tails = ((3,), (), (), (2,), (3,))
        return {n: a.reshape(lead + t) for n, a, t in zip(names, out, tails)}

    def compute_distance(self, query_points: npt.ArrayLike, nthreads: int = 0) -> np.ndarray:
        """The world distance from each query ``(..., 3)`` to the nearest instance: float32, of the leading shape.

        As :meth:`TriangleTree.compute_distance`; NaN for a query with a
        NaN or infinite coordinate, inf for a scene with no instances.
        """
        q, lead = _points(query_points)
        return self._tree.distances(q, _nthreads(nthreads)).reshape(lead)  # type: ignore[no-any-return]

    def compute_signed_distance(self, *args: Any, **kwargs: Any) -> np.ndarray:
        """Not offered on a scene: raises ``NotImplementedError``.

        The inside rules compose over instances (a ray's crossings add), but
        counting each crossing once through the top level is not built;
        build a :class:`TriangleTree` from the scene's mesh file to sign.
        """
        raise NotImplementedError(_NO_SCENE_SIGN)

    def compute_occupancy(self, *args: Any, **kwargs: Any) -> np.ndarray:
        """Not offered on a scene: raises ``NotImplementedError`` (see :meth:`compute_signed_distance`)."""
        raise NotImplementedError(_NO_SCENE_SIGN)

    def __reduce_ex__(self, protocol: Any) -> tuple[Any, tuple[Any, ...]]:
        return _reduce(self, int(protocol), _scene)

    def __repr__(self) -> str:
        return f"kdray.Scene({self.instance_count} instances of {self.mesh_count} meshes)"


# --- points ----------------------------------------------------------------


def _physical_memory() -> int:
    """This machine's memory in bytes, or 2**62 where the system does not say."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return 2**62


class KDTree(_Blob):
    """A point k-d tree with ``scipy.spatial.KDTree``'s ``query`` and ``query_ball_point``.

    ``data`` is ``(n, m)`` with ``m`` from 1 to :data:`MAX_DIM`; float32
    data is kept (and searched) in float32, float64 in float64, other
    numbers converted to float64. ``leafsize``: points a leaf at most
    (default: kdray's 32 below 8-D, 64 from 8-D on; scipy's is 16).
    Distances are Euclidean (``p=2``), exact, in the tree's dtype.
    scipy's ``boxsize`` (periodic space) is not supported.
    """

    __slots__ = ("_tree",)
    _tree: _kdray.PointTree

    def __init__(
        self,
        data: npt.ArrayLike,
        leafsize: int | None = None,
        compact_nodes: bool = True,
        copy_data: bool = False,
        balanced_tree: bool = True,
        boxsize: Any = None,
    ) -> None:
        if boxsize is not None:
            raise NotImplementedError("boxsize: kdray's KDTree has no periodic space")
        a = _array(data, "data")
        if a.ndim != 2:
            raise ValueError(f"data: expected shape (n, m), got {a.shape}")
        n, m = a.shape
        if n == 0:
            raise ValueError("data: no points")
        if not 1 <= m <= MAX_DIM:
            raise NotImplementedError(
                f"data: {m}-dimensional points: kdray's KDTree takes 1 to {MAX_DIM} dimensions"
            )
        if a.dtype not in (np.float32, np.float64):
            a = a.astype(np.float64)
        if leafsize is not None and int(leafsize) < 1:
            raise ValueError(f"leafsize must be at least 1, not {leafsize}")
        a = np.ascontiguousarray(a)
        _finite_rows(a, "data")
        self._tree = _kdray.PointTree.build(a, None if leafsize is None else int(leafsize))

    @classmethod
    def from_bytes(cls, buffer: Any, *, copy: bool = False) -> KDTree:
        """A tree from its blob (``kdray build-points``' output), validated; read in place when read-only and 8-byte aligned."""
        return cls._wrap(_kdray.PointTree.from_buffer(buffer, copy))

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> KDTree:
        """Reads and validates a point blob file."""
        return cls._wrap(_kdray.PointTree.load(os.fspath(path)))

    @property
    def n(self) -> int:
        """How many points."""
        return self._tree.n

    @property
    def m(self) -> int:
        """Their dimension."""
        return self._tree.dim

    @property
    def dtype(self) -> np.dtype[Any]:
        """float32 or float64: the points' and the distances' type."""
        return np.dtype(self._tree.dtype)

    @property
    def data(self) -> np.ndarray:
        """The points, ``(n, m)``, in input order (rebuilt from the tree: a new array)."""
        return self._tree.data()

    def _queries(self, x: npt.ArrayLike) -> tuple[np.ndarray, tuple[int, ...]]:
        q = _array(x, "x")
        if q.ndim < 1 or q.shape[-1] != self.m:
            raise ValueError(
                f"x: expected shape (..., {self.m}) for the tree's {self.m}-D points, got {q.shape}"
            )
        lead = q.shape[:-1]
        if q.dtype == self.dtype:
            return np.ascontiguousarray(q.reshape(-1, self.m)), lead
        with np.errstate(over="ignore", invalid="ignore"):  # beyond float32: inf, no neighbour
            return np.ascontiguousarray(q.reshape(-1, self.m), dtype=self.dtype), lead

    def query(
        self,
        x: npt.ArrayLike,
        k: int | Sequence[int] = 1,
        eps: float = 0,
        p: float = 2,
        distance_upper_bound: float = np.inf,
        workers: int = 1,
    ) -> tuple[Any, Any]:
        """The ``k`` nearest points of each query, as ``scipy.spatial.KDTree.query``.

        Returns ``(d, i)``: Euclidean distances (the tree's dtype) and
        indices (int64), shaped ``x.shape[:-1]`` for ``k=1``,
        ``x.shape[:-1] + (k,)`` for a larger int ``k``, and
        ``x.shape[:-1] + (len(k),)`` for a list of 1-based ranks. Only
        points at a distance below ``distance_upper_bound`` count; a
        missing neighbour is ``d = inf``, ``i = n``. Ties: the lower index
        first. ``eps`` may be any value >= 0: the answer is exact, so it
        meets any bound. ``p`` must be 2. ``workers``: threads, -1 for all
        cores.
        """
        if p != 2:
            raise NotImplementedError(f"p={p}: kdray's KDTree measures Euclidean distance (p=2) only")
        if not eps >= 0:
            raise ValueError(f"eps must be non-negative, not {eps}")
        threads = _workers(workers)
        if isinstance(k, (int, np.integer)):
            ranks = None
            kmax = int(k)
        else:
            ranks = np.asarray(k)
            if ranks.ndim != 1 or ranks.size == 0 or ranks.dtype.kind not in "iu":
                raise ValueError(f"k: expected an int or a list of 1-based ranks, got {k!r}")
            kmax = int(ranks.max())
            if int(ranks.min()) < 1:
                raise ValueError(f"k: ranks start at 1, got {k!r}")
        if kmax < 1:
            raise ValueError(f"k must be at least 1, not {kmax}")
        ub = float(distance_upper_bound)
        if np.isnan(ub):
            raise ValueError("distance_upper_bound is NaN")
        q, lead = self._queries(x)
        m = q.shape[0]
        if m * kmax > 2**40:
            raise ValueError(f"k={kmax}: {m} queries x {kmax} neighbours is too many to return")
        # Refused before any work, not left to the allocation: where memory
        # is overcommitted, filling an answer past it kills the process.
        size = m * kmax * (self.dtype.itemsize + 8)
        if size > _physical_memory():
            raise ValueError(
                f"k={kmax}: the answer, {m} x {kmax} distances and indices ({size} bytes), does not fit in memory"
            )
        dt = self.dtype.type
        if ub == np.inf:
            max_d2 = np.inf
        elif ub <= 0:
            max_d2 = -1.0
        else:
            # Strictly below the bound, as scipy: the largest squared distance under ub².
            max_d2 = float(np.nextafter(np.square(dt(ub)), dt(-np.inf)))
        k_run = min(kmax, self.n)
        d2, idx = self._tree.knn(q, k_run, max_d2, threads)
        d = np.sqrt(d2)
        if kmax > k_run:
            d = np.concatenate([d, np.full((m, kmax - k_run), np.inf, dtype=d.dtype)], axis=1)
            idx = np.concatenate([idx, np.full((m, kmax - k_run), self.n, dtype=idx.dtype)], axis=1)
        if ranks is not None:
            d, idx = d[:, ranks - 1], idx[:, ranks - 1]
            shape = lead + (len(ranks),)
        elif kmax == 1:
            shape = lead
        else:
            shape = lead + (kmax,)
        d, idx = d.reshape(shape), idx.reshape(shape)
        if shape == ():
            return d[()], idx[()]
        return d, idx

    def query_ball_point(
        self,
        x: npt.ArrayLike,
        r: npt.ArrayLike,
        p: float = 2.0,
        eps: float = 0,
        workers: int = 1,
        return_sorted: bool | None = None,
        return_length: bool = False,
    ) -> Any:
        """The points within distance ``r`` (inclusive) of each query, as scipy's.

        For one query (``x`` of shape ``(m,)``) a list of indices, else an
        object array of lists of ``x.shape[:-1]``; with
        ``return_length=True`` the counts instead. Indices are always in
        ascending order (so any ``return_sorted`` holds). ``r`` broadcasts
        to ``x.shape[:-1]``. ``p`` must be 2; ``eps`` >= 0 (exact answers).
        """
        if p != 2:
            raise NotImplementedError(f"p={p}: kdray's KDTree measures Euclidean distance (p=2) only")
        if not eps >= 0:
            raise ValueError(f"eps must be non-negative, not {eps}")
        threads = _workers(workers)
        q, lead = self._queries(x)
        radii = _array(r, "r")
        if np.isnan(radii).any():
            raise ValueError("r: NaN radius")
        try:
            radii = np.broadcast_to(radii, lead).reshape(-1)
        except ValueError:
            raise ValueError(f"r: shape {radii.shape} does not broadcast to {lead}") from None
        dt = self.dtype
        r_dt = radii.astype(dt)
        r2 = np.where(r_dt >= 0, np.square(r_dt), dt.type(-1)).astype(dt)
        splits, indices = self._tree.within(q, np.ascontiguousarray(r2), threads)
        counts = np.diff(splits).astype(np.intp)
        if return_length:
            return counts.reshape(lead)[()] if lead == () else counts.reshape(lead)
        flat = indices.tolist()
        bounds = splits.tolist()
        lists = [flat[bounds[j] : bounds[j + 1]] for j in range(len(bounds) - 1)]
        if lead == ():
            return lists[0]
        out = np.empty(len(lists), dtype=object)
        out[:] = lists
        return out.reshape(lead)

    def __reduce_ex__(self, protocol: Any) -> tuple[Any, tuple[Any, ...]]:
        return _reduce(self, int(protocol), _kd_tree)

    def __repr__(self) -> str:
        return f"kdray.KDTree({self.n} points, m={self.m}, {self.dtype})"


def _workers(workers: int) -> int:
    """scipy's ``workers`` (-1: all cores) as a thread count (0: all cores)."""
    w = _whole(workers, "workers")
    if w == -1:
        return 0
    if w < 1:
        raise ValueError(f"workers must be -1 (all cores) or at least 1, not {workers}")
    return w


def _triangle_tree(buffer: Any) -> TriangleTree:
    return TriangleTree.from_bytes(buffer)


def _scene(buffer: Any) -> Scene:
    return Scene.from_bytes(buffer)


def _kd_tree(buffer: Any) -> KDTree:
    return KDTree.from_bytes(buffer)
