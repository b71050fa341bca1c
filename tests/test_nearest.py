"""The k-d tree of the test points (pykdtree behind `PointTree`) against scipy's cKDTree, whose
conventions it keeps: the same distances and neighbours, a missing neighbour at index N and
distance inf."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from checker.geometry.nearest import PointTree


@pytest.mark.parametrize("k", [1, 2, 9])
def test_neighbours_agree_with_scipy(k):
    rng = np.random.default_rng(7)
    points = rng.normal(size=(5000, 3)) * [40.0, 20.0, 5.0]
    queries = rng.normal(size=(700, 3)) * [50.0, 25.0, 8.0]
    dist, idx = PointTree(points).query(queries, k=k)
    ref_dist, ref_idx = cKDTree(points).query(queries, k=k)
    assert idx.dtype == np.intp and idx.shape == ref_idx.shape
    np.testing.assert_allclose(dist, ref_dist, rtol=0, atol=1e-12)
    # the same neighbours, up to the order of exact ties: each at its distance
    m = len(queries)
    at = np.linalg.norm(points[idx.reshape(m, -1)] - queries[:, None], axis=-1)
    np.testing.assert_allclose(at, ref_dist.reshape(m, -1), rtol=0, atol=1e-12)


def test_more_neighbours_than_points_as_scipy_says():
    points = np.array([[0.0, 0, 0], [1, 0, 0], [0, 2, 0]])
    dist, idx = PointTree(points).query(np.array([[0.1, 0, 0]]), k=5)
    ref_dist, ref_idx = cKDTree(points).query(np.array([[0.1, 0, 0]]), k=5)
    assert idx.tolist() == ref_idx.tolist() == [[0, 1, 2, 3, 3]]
    np.testing.assert_allclose(dist, ref_dist)
    assert np.isinf(dist[0, 3:]).all()


def test_an_empty_tree_has_no_neighbours_as_scipy_says():
    dist, idx = PointTree(np.zeros((0, 3))).query(np.ones((2, 3)))
    ref_dist, ref_idx = cKDTree(np.zeros((0, 3))).query(np.ones((2, 3)))
    assert idx.tolist() == ref_idx.tolist() == [0, 0] and np.isinf(dist).all()
