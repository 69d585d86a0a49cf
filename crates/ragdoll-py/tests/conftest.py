"""Shared helpers: quaternion maths on (…, 4) x y z w arrays, written here with numpy
alone so the checks share no code with the engine."""

import os
import pathlib

import numpy as np
import pytest


def qmul(a, b):
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=-1,
    )


def qinv(q):
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


def qrot(q, v):
    """Rotates vectors v (…, 3) by unit quaternions q (…, 4)."""
    u = q[..., :3]
    w = q[..., 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def data_dir():
    """The shared test data beside the repository, or None on a bare clone."""
    env = os.environ.get("RAGDOLL_DATA")
    if env:
        return pathlib.Path(env)
    here = pathlib.Path(__file__).resolve()
    for up in here.parents:
        d = up.parent / "shared" / "data"
        if (up / "Cargo.toml").exists() and d.is_dir():
            return d
    return None


@pytest.fixture
def data():
    d = data_dir()
    if d is None or not d.is_dir():
        pytest.skip("needs ../shared/data")
    return d
