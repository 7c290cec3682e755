"""Pickling as the blob, and calls from several Python threads at once."""

from __future__ import annotations

import pickle
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from conftest import random_rays, sphere

import kdray


def trees() -> list[object]:
    v, f = sphere()
    pts = np.random.default_rng(1).random((2000, 3))
    return [kdray.TriangleTree(v, f), kdray.KDTree(pts), kdray.KDTree(pts.astype(np.float32))]


@pytest.mark.parametrize("protocol", range(2, pickle.HIGHEST_PROTOCOL + 1))
def test_pickle_round_trip(protocol: int) -> None:
    for tree in trees():
        again = pickle.loads(pickle.dumps(tree, protocol=protocol))
        assert type(again) is type(tree)
        assert again.to_bytes() == tree.to_bytes()  # type: ignore[attr-defined]


def test_pickle_protocol_5_out_of_band() -> None:
    for tree in trees():
        buffers: list[pickle.PickleBuffer] = []
        data = pickle.dumps(tree, protocol=5, buffer_callback=buffers.append)
        assert len(buffers) == 1
        assert len(data) < 200  # the blob went out of band
        again = pickle.loads(data, buffers=buffers)
        assert again.to_bytes() == tree.to_bytes()  # type: ignore[attr-defined]


def test_unpickled_blob_is_validated() -> None:
    tree = trees()[0]
    data = bytearray(pickle.dumps(tree, protocol=4))
    blob = tree.to_bytes()  # type: ignore[attr-defined]
    at = data.find(blob[200:232])
    data[at + 5] ^= 0xFF
    with pytest.raises(kdray.BlobError, match="checksum|invalid|not a valid"):
        pickle.loads(bytes(data))


def test_threads_at_once() -> None:
    tri, pts, _ = trees()
    rays = random_rays(20_000, np.array([-2.0] * 3), np.array([2.0] * 3), 3)
    x = np.random.default_rng(4).random((20_000, 3))
    want_hits = tri.cast_rays(rays)  # type: ignore[attr-defined]
    want_knn = pts.query(x, k=4)  # type: ignore[attr-defined]

    def work(j: int) -> None:
        for _ in range(3):
            if j % 2:
                got = tri.cast_rays(rays, nthreads=j % 3)  # type: ignore[attr-defined]
                np.testing.assert_array_equal(got["t_hit"], want_hits["t_hit"])
                np.testing.assert_array_equal(got["primitive_ids"], want_hits["primitive_ids"])
            else:
                d, i = pts.query(x, k=4, workers=1 + j % 2)  # type: ignore[attr-defined]
                np.testing.assert_array_equal(d, want_knn[0])
                np.testing.assert_array_equal(i, want_knn[1])

    with ThreadPoolExecutor(6) as ex:
        for f in [ex.submit(work, j) for j in range(12)]:
            f.result()
