"""Pushes, fields, pins, drags and motors through Python: each does what it says, measured
on the joint transforms."""

import numpy as np
import pytest

import ragdoll_sim as rd
from test_physics import com_track


def free_world(backend="rigid"):
    return rd.World(backend, gravity=(0, 0, 0), ground=None)


def test_an_impulse_gives_its_momentum():
    w = free_world()
    c = rd.humanoid()
    h = w.add(c)
    w.add_push(h, "chest", impulse_ns=(30.0, 0.0, 0.0), time_s=0.1)
    r = w.run(1.0, fps=30)
    com, mass = com_track(r, h, r.spec(h))
    v = (com[30] - com[20]) * 3.0
    assert np.linalg.norm(com[2] - com[0]) < 1e-5  # nothing before the push
    np.testing.assert_allclose(mass * v, [30.0, 0.0, 0.0], atol=0.3)


def test_a_force_over_a_window_gives_force_times_time():
    w = free_world()
    h = w.add(rd.humanoid())
    w.add_push(h, "pelvis", force_n=(0.0, 0.0, 75.0), start_s=0.0, end_s=0.5)
    r = w.run(1.0, fps=30)
    com, mass = com_track(r, h, r.spec(h))
    v = (com[30] - com[24]) * 5.0
    np.testing.assert_allclose(mass * v, [0.0, 0.0, 75.0 * 0.5], atol=0.75)


def test_wind_pushes_the_body_downwind():
    w = free_world()
    h = w.add(rd.humanoid())
    w.add_field("wind", velocity_mps=(20.0, 0.0, 0.0))
    r = w.run(1.0)
    com, _ = com_track(r, h, r.spec(h))
    d = com[-1] - com[0]
    assert d[0] > 0.05 and abs(d[2]) < 0.2 * d[0], d


def test_a_gravity_field_replaces_gravity():
    w = rd.World("rigid", ground=None)
    h = w.add(rd.humanoid())
    w.add_field("gravity", keys=[(0.0, (0.0, -1.0, 0.0))])
    r = w.run(1.0, fps=30)
    y = r.transforms(h, space="world")[:, 0, 1]
    drop = y[0] - y[-1]
    assert drop == pytest.approx(0.5 * 1.0 * 1.0**2, rel=0.05), drop


def test_a_pin_holds_a_part_and_a_drag_carries_it():
    c = rd.humanoid()
    head = c.joint_names.index("head")
    w = rd.World("rigid")
    h = w.add(c)
    start = c.rest_world[head, 0:3]
    w.add_pin(h, "head", tuple(start))
    r = w.run(2.0)
    held = r.transforms(h, space="world")[:, head, 0:3]
    assert np.linalg.norm(held - start, axis=1).max() < 0.02
    w = rd.World("rigid")
    h = w.add(c)
    to = start + np.array([1.0, 0.0, 0.0])
    w.add_drag(h, "head", [(0.0, tuple(start)), (1.0, tuple(to))])
    r = w.run(1.5)
    got = r.transforms(h, space="world")[-1, head, 0:3]
    assert np.linalg.norm(got - to) < 0.05, got


def test_motors_follow_the_animation():
    c0 = rd.humanoid()
    names, parents, rest = c0.joint_names, c0.parents, c0.rest_local
    frames = np.repeat(rest[None], 61, axis=0)  # two seconds of standing still
    c = rd.Character.from_arrays(names, parents, rest, frames=frames, fps=30, tips=c0.tips)
    limp, powered = [], []
    for motors, out in ((None, limp), ({"strength": 1.0, "root_on_clip": True}, powered)):
        w = rd.World("rigid")
        h = w.add(c, powered=motors)
        r = w.run(2.0)
        out.append(r.transforms(h))
    # Powered, the ragdoll holds the clip's pose (here the rest pose) against gravity; limp,
    # it falls.
    def worst_deg(local):
        q, q0 = local[:, :, 3:7], rest[None, :, 3:7]
        dots = np.clip(np.abs((q * q0).sum(-1)), 0, 1)
        return np.degrees(2 * np.arccos(dots))[:, 1:].max()

    assert worst_deg(powered[0]) < 5.0
    assert worst_deg(limp[0]) > 20.0
