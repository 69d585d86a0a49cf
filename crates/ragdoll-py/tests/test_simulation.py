"""A simulation stepped a piece at a time, with ragdolls added and removed between steps:
physical facts through Python."""

import numpy as np
import pytest

import ragdoll_sim as rd

G = 9.80665


def centre_of_mass(sim, handle, spec):
    poses = sim.body_poses(handle)
    masses = np.array([b.mass_kg for b in spec.bodies])
    return (poses[:, 0:3] * masses[:, None]).sum(axis=0) / masses.sum()


@pytest.mark.parametrize("backend", ["rigid", "fast", "particle"])
def test_a_ragdoll_added_between_steps_falls_freely(backend):
    sim = rd.Simulation(backend, ground=None)
    spec = rd.build_ragdoll(rd.humanoid())
    first = sim.add(rd.humanoid(), spec)
    sim.step(0.5)
    assert sim.time == pytest.approx(0.5)
    late = sim.add(rd.humanoid(), spec, at=(4.0, 0.0, 0.0))
    start = centre_of_mass(sim, late, spec)
    sim.step(0.5)
    drop = start[1] - centre_of_mass(sim, late, spec)[1]
    assert drop == pytest.approx(0.5 * G * 0.5**2, abs=0.02)
    # Both tracks have a frame per output frame: 1 s at 30 fps and the first.
    assert sim.transforms(first).shape == (31, len(rd.humanoid().joint_names), 10)
    assert sim.transforms(late).shape == sim.transforms(first).shape
    assert len(sim) == 2


@pytest.mark.parametrize("backend", ["rigid", "fast", "particle"])
def test_a_removed_ragdoll_stops_where_it_is(backend):
    # Two fall freely; one is removed after 0.3 s: it stops there, its track holds that
    # pose, and the other falls on as free bodies do.
    spec = rd.build_ragdoll(rd.humanoid())
    sim = rd.Simulation(backend, ground=None)
    gone = sim.add(rd.humanoid(), spec)
    stays = sim.add(rd.humanoid(), spec, at=(3.0, 0.0, 0.0))
    sim.step(0.3)
    sim.remove(gone)
    held = sim.body_poses(gone)
    start = centre_of_mass(sim, stays, spec)
    velocity = G * 0.3
    sim.step(0.3)
    assert np.abs(sim.body_poses(gone)[:, 0:3] - held[:, 0:3]).max() < 1e-4
    track = sim.transforms(gone)
    assert np.abs(track[-1, :, 0:3] - track[9, :, 0:3]).max() < 1e-4
    drop = start[1] - centre_of_mass(sim, stays, spec)[1]
    assert drop == pytest.approx(velocity * 0.3 + 0.5 * G * 0.3**2, abs=0.03)


@pytest.mark.parametrize("backend", ["rigid", "fast", "particle"])
def test_a_blast_added_between_steps_goes_off_then_and_throws_away_from_the_charge(backend):
    # Zero gravity, no ground: a humanoid floats; half a second in, 2 kg of TNT goes off
    # 2 m to its side. Before, it has no momentum; after, its momentum points away.
    spec = rd.build_ragdoll(rd.humanoid())
    sim = rd.Simulation(backend, ground=None, gravity=(0.0, 0.0, 0.0))
    h = sim.add(rd.humanoid(), spec)
    sim.step(0.5)
    masses = np.array([b.mass_kg for b in spec.bodies])
    centre = centre_of_mass(sim, h, spec)
    charge = centre + np.array([2.0, 0.0, 0.0])
    sim.add_blast(2.0, tuple(charge), air=True)
    before = centre.copy()
    sim.step(0.5)
    moved = centre_of_mass(sim, h, spec) - before
    assert moved[0] < -0.1, moved                      # away from the charge, along -x
    assert abs(moved[0]) > 5 * np.abs(moved[1:]).max(), moved


def momentum(sim, handle, spec):
    masses = np.array([b.mass_kg for b in spec.bodies])
    return (sim.body_velocities(handle)[:, 0:3] * masses[:, None]).sum(axis=0)


@pytest.mark.parametrize("backend", ["rigid", "fast", "particle"])
def test_shots_and_pushes_added_between_steps_deliver_their_momentum(backend):
    # Zero gravity, no ground: a humanoid floats; 0.3 s in, a 50 g shot at 400 m/s along
    # +z hits its chest, and a 30 N·s push along +x its pelvis: its momentum is theirs.
    spec = rd.build_ragdoll(rd.humanoid())
    sim = rd.Simulation(backend, ground=None, gravity=(0.0, 0.0, 0.0))
    h = sim.add(rd.humanoid(), spec)
    sim.step(0.3)
    before = momentum(sim, h, spec)
    chest = sim.body_poses(h)[[b.name for b in spec.bodies].index("chest"), 0:3]
    sim.add_projectile(tuple(chest - np.array([0.0, 0.0, 3.0])), direction=(0.0, 0.0, 1.0), mass_kg=0.05, speed_mps=400.0)
    sim.add_push(h, "pelvis", (30.0, 0.0, 0.0))
    sim.step(0.2)
    gained = momentum(sim, h, spec) - before
    assert gained == pytest.approx([30.0, 0.0, 20.0], abs=0.3), gained


def test_bad_calls_raise_in_a_sentence():
    sim = rd.Simulation("fast")
    h = sim.add(rd.humanoid())
    with pytest.raises(rd.BoundError, match="is not a ragdoll of this simulation"):
        sim.body_poses(h + 1)
    with pytest.raises(rd.BoundError, match="zero or more"):
        sim.step(-1.0)
    sim.remove(h)
    with pytest.raises(rd.RagdollError, match="removed already"):
        sim.remove(h)
    with pytest.raises(rd.BoundError, match="seconds"):
        sim.step(1.0e9)


def momentum(sim, handle, spec):
    masses = np.array([b.mass_kg for b in spec.bodies])
    return (sim.body_velocities(handle)[:, 0:3] * masses[:, None]).sum(axis=0)


@pytest.mark.parametrize("backend", ["rigid", "fast", "particle"])
def test_a_drag_field_added_between_steps_acts_from_then(backend):
    # Zero gravity, no ground: a humanoid shoved at 0.4 m/s keeps its momentum until a
    # drag of 4 per second is added 0.2 s in; 0.5 s later it keeps exp(-2) of it.
    spec = rd.build_ragdoll(rd.humanoid())
    sim = rd.Simulation(backend, ground=None, gravity=(0.0, 0.0, 0.0))
    h = sim.add(rd.humanoid(), spec)
    sim.add_push(h, "pelvis", (30.0, 0.0, 0.0))
    sim.step(0.2)
    before = momentum(sim, h, spec)
    assert before[0] == pytest.approx(30.0, rel=0.01)
    sim.add_field("drag", rate_per_s=4.0)
    sim.step(0.5)
    after = momentum(sim, h, spec)
    assert after[0] / before[0] == pytest.approx(np.exp(-2.0), rel=0.15)


@pytest.mark.parametrize("backend", ["rigid", "fast", "particle"])
def test_a_pin_added_between_steps_holds_a_falling_ragdoll(backend):
    # A humanoid falls freely for 0.3 s; its head joint is then pinned where it is: a
    # second later the joint is still there and the body hangs from it instead of
    # falling the 7 m free bodies fall in that time.
    spec = rd.build_ragdoll(rd.humanoid())
    sim = rd.Simulation(backend, ground=None)
    h = sim.add(rd.humanoid(), spec)
    sim.step(0.3)
    head = rd.humanoid().joint_names.index("head")
    at = sim.transforms(h)[-1, head, 0:3].copy()
    sim.add_pin(h, "head", tuple(at))
    start = centre_of_mass(sim, h, spec)
    sim.step(1.0)
    assert np.linalg.norm(sim.transforms(h)[-1, head, 0:3] - at) < 0.03
    assert start[1] - centre_of_mass(sim, h, spec)[1] < 0.5
    with pytest.raises(rd.BoundError):
        sim.add_pin(h, "head")
    with pytest.raises(rd.BoundError):
        sim.add_field("wind")
