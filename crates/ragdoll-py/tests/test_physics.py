"""Physical facts, asserted through Python: what a user's script sees."""

import numpy as np
import pytest

import ragdoll_sim as rd
from conftest import qinv, qmul, qrot

G = 9.80665


def com_track(result, handle, spec):
    """The centre of mass per frame, from the joint transforms and the spec's bodies."""
    world = result.transforms(handle, space="world")
    names = list(result_character_names(result, handle))
    masses = np.array([b.mass_kg for b in spec.bodies])
    bones = [names.index(b.bone) for b in spec.bodies]
    centres = np.array([b.center_m for b in spec.bodies])
    pos = world[:, bones, 0:3] + qrot(world[:, bones, 3:7], np.broadcast_to(centres, (world.shape[0],) + centres.shape))
    return (pos * masses[None, :, None]).sum(axis=1) / masses.sum(), masses.sum()


def result_character_names(result, handle):
    return HUMANOID_NAMES


HUMANOID_NAMES = rd.humanoid().joint_names


@pytest.mark.parametrize("backend", ["rigid", "fast", "particle"])
def test_free_fall_drops_half_g_t_squared(backend):
    world = rd.World(backend, ground=None)
    h = world.add(rd.humanoid())
    result = world.run(0.5, fps=30)
    y = result.transforms(h, space="world")[:, 0, 1]
    t = np.arange(len(y)) / 30.0
    drop = y[0] - y
    # A first-order integrator at the world's 1/60 s step may lag ½gt² by at most g·dt·t.
    assert np.all(np.abs(drop - 0.5 * G * t**2) <= G * (1 / 60) * t + 1e-4), drop


def test_a_blast_pushes_the_body_away_and_momentum_is_kept_after():
    world = rd.World("rigid", gravity=(0, 0, 0), ground=None)
    c = rd.humanoid()
    spec = rd.build_ragdoll(c)
    h = world.add(c, spec)
    charge = np.array([3.0, 1.0, 0.0])
    world.add_blast(2.0, charge, time_s=0.05, air=True)
    result = world.run(1.0, fps=30)
    com, mass = com_track(result, h, result.spec(h))
    # Before the blast front arrives nothing moves.
    assert np.linalg.norm(com[1] - com[0]) < 1e-4
    # After it, no external force: the centre of mass moves at one velocity.
    v_early = (com[15] - com[9]) * 30 / 6
    v_late = (com[30] - com[24]) * 30 / 6
    assert np.linalg.norm(v_late - v_early) < 0.01 * np.linalg.norm(v_late)
    # Away from the charge.
    away = com[0] - charge
    assert np.dot(v_late, away) > 0.9 * np.linalg.norm(v_late) * np.linalg.norm(away)
    # The momentum is what the blast gave: no more than the sum of the parts' impulses,
    # and (the parts all lie within ~25° of the same direction from the charge) no less
    # than 0.85 of it.
    given = sum(p["impulse_ns"] for p in result.report["blasts"][0]["parts"])
    p = mass * np.linalg.norm(v_late)
    assert 0.85 * given <= p <= given * 1.001, (p, given)


def hinge_angles_deg(character, result, handle, spec, joint):
    """A hinge's angle per frame, measured from the bones' world rotations."""
    names = character.joint_names
    child_body = spec.body(joint.child)
    parent_body = spec.body(joint.parent)
    ci, pi = names.index(child_body.bone), names.index(parent_body.bone)
    rest = character.rest_world
    world = result.transforms(handle, space="world")
    frame = np.array(spec_joint_frame(spec, joint.name))
    # The parent side of the joint frame, in the parent bone's frame, fixed at rest.
    parent_side = qmul(qmul(qinv(rest[pi, 3:7]), rest[ci, 3:7]), frame)
    pw = qmul(world[:, pi, 3:7], parent_side)
    cw = qmul(world[:, ci, 3:7], frame)
    q = qmul(qinv(pw), cw)
    q = q * np.sign(q[:, 3:4] + 1e-12)
    return np.degrees(2 * np.arctan2(q[:, 0], q[:, 3])), np.degrees(2 * np.arcsin(np.clip(np.linalg.norm(q[:, 1:3], axis=1), 0, 1)))


def spec_joint_frame(spec, name):
    import tomllib

    table = tomllib.loads(spec.to_toml())
    return next(j["frame"] for j in table["joints"] if j["name"] == name)


@pytest.mark.parametrize("backend", ["rigid", "fast"])
def test_knees_and_elbows_stay_within_their_limits_in_a_blast(backend):
    c = rd.humanoid()
    spec = rd.build_ragdoll(c)
    world = rd.World(backend)
    h = world.add(c, spec)
    world.add_blast(5.0, (1.5, 0.0, 0.5), time_s=0.1)
    result = world.run(2.0, fps=60)
    hinges = [j for j in spec.joints if j.kind == "hinge"]
    assert len(hinges) == 4
    for j in hinges:
        angle, off_axis = hinge_angles_deg(c, result, h, spec, j)
        # Knees and elbows never bend backwards: the rest pose is 0, flexion positive.
        assert j.min_deg <= 1.0, j
        assert angle.min() >= j.min_deg - 3.0, (j.name, angle.min())
        assert angle.max() <= j.max_deg + 3.0, (j.name, angle.max())
        assert off_axis.max() < 5.0, (j.name, off_axis.max())
        # The blast does bend them: the measurement is not of a frozen pose.
    moved = max(np.ptp(hinge_angles_deg(c, result, h, spec, j)[0]) for j in hinges)
    assert moved > 10.0
