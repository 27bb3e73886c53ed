"""Shared helpers of the bubblemesh Python tests."""

import importlib
import os
import pathlib

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
FIXTURES = ROOT / "fixtures" / "step"


def need(module):
    """Imports `module`; without it the test skips with the reason printed,
    except under CI (env CI set), where it fails."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        if os.environ.get("CI"):
            pytest.fail(f"{module} is required under CI (python/ci.sh installs it): {e}")
        print(f"SKIP: {module} is not installed ({e})")
        pytest.skip(f"{module} is not installed")


def tet_volumes(points, tets):
    """Signed volume of each tetrahedron (positive when a, b, c, d is
    counter-clockwise seen from outside: (b-a)x(c-a) points towards d)."""
    a, b, c, d = (points[tets[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6.0


def unique_edges(elements):
    """The unique edges (sorted node pairs) of triangles or tetrahedra."""
    k = elements.shape[1]
    pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
    e = np.concatenate([elements[:, [i, j]] for i, j in pairs])
    e.sort(axis=1)
    return np.unique(e, axis=0)


@pytest.fixture
def square():
    return str(EXAMPLES / "square.toml")
