"""The package's API: arrays in and out, specs that round-trip, errors as exceptions with
their place, cancellation and the interpreter's lock."""

import pathlib
import threading
import time
import _thread

import numpy as np
import pytest

import ragdoll_sim as rd
from ragdoll_sim import _native


def humanoid_arrays():
    c = rd.humanoid()
    return c.joint_names, c.parents, c.rest_local


def test_a_rig_handed_over_as_arrays_is_the_same_character():
    names, parents, rest = humanoid_arrays()
    assert rest.shape == (17, 10) and rest.dtype == np.float64
    tips = rd.humanoid().tips
    assert np.isnan(tips).any() and not np.isnan(tips).all()
    c = rd.Character.from_arrays(names, parents, rest.astype(np.float32), tips=tips, name="arrays")
    np.testing.assert_array_equal(c.tips, tips)
    assert c.joint_names == names and c.parents == parents
    np.testing.assert_allclose(c.rest_world, rd.humanoid().rest_world, atol=1e-6)
    assert dict(c.roles.found) == dict(rd.humanoid().roles.found)
    # The same rig simulates the same way, frame for frame.
    runs = []
    for ch in (rd.humanoid(), c):
        w = rd.World("rigid")
        h = w.add(ch)
        w.add_blast(3.0, (1.0, 0.0, 1.0), time_s=0.1)
        runs.append(w.run(1.0).transforms(h))
    np.testing.assert_array_equal(runs[0], runs[1])


def test_local_transforms_compose_to_the_world_ones():
    from conftest import qmul, qrot

    c = rd.humanoid()
    w = rd.World("fast")
    h = w.add(c, at=(1.0, 0.0, -2.0), facing_deg=90)
    r = w.run(0.5)
    local, world = r.transforms(h), r.transforms(h, space="world")
    assert local.shape == world.shape == (r.frames, 17, 10)
    fk = np.empty_like(local)
    for j, p in enumerate(c.parents):
        if p < 0:
            fk[:, j] = local[:, j]
            continue
        fk[:, j, 3:7] = qmul(fk[:, p, 3:7], local[:, j, 3:7])
        fk[:, j, 0:3] = fk[:, p, 0:3] + qrot(fk[:, p, 3:7], local[:, j, 0:3] * fk[:, p, 7:10])
        fk[:, j, 7:10] = local[:, j, 7:10]
    np.testing.assert_allclose(fk[..., 0:3], world[..., 0:3], atol=1e-4)
    dots = np.abs(np.sum(fk[..., 3:7] * world[..., 3:7], axis=-1))
    assert dots.min() > 1 - 1e-5
    # The character stands where it was put.
    assert np.linalg.norm(world[0, 0, [0, 2]] - [1.0, -2.0]) < 0.05


def test_a_rig_of_implausible_size_gets_a_warning():
    names, parents, rest = humanoid_arrays()
    assert rd.Character.from_arrays(names, parents, rest).warnings == []
    big = rest.copy()
    big[:, 0:3] *= 100.0  # a rig in centimetres read as metres
    (w,) = rd.Character.from_arrays(names, parents, big).warnings
    assert "tall" in w and "units" in w


def test_a_mesh_and_an_animation_come_in_as_arrays():
    names, parents, rest = humanoid_arrays()
    world = rd.humanoid().rest_world
    # A strip of skin along the legs, each vertex on the joint it lies at.
    idx = [names.index(n) for n in ("thigh_l", "shin_l", "foot_l", "thigh_r", "shin_r", "foot_r")]
    positions = world[idx, 0:3]
    joints = np.zeros((6, 4), dtype=np.int32)
    joints[:, 0] = idx
    weights = np.zeros((6, 4))
    weights[:, 0] = 2.0  # not normalised: repaired with a warning
    mesh = {"positions": positions, "triangles": [[0, 1, 3], [1, 4, 3], [1, 2, 4], [2, 5, 4]],
            "joints": joints, "weights": weights}
    frames = np.repeat(rest[None], 10, axis=0)
    c = rd.Character.from_arrays(names, parents, rest, mesh=mesh, frames=frames, fps=30)
    assert c.mesh_count == 1 and c.clips == ["clip"]
    assert any("renormalised" in w for w in c.warnings)
    w = rd.World("rigid")
    h = w.add(c, activate=0.2)
    r = w.run(0.5)
    assert r.report["characters"][0]["activated_at_s"] == pytest.approx(0.2, abs=1 / 60)


def test_specs_are_edited_in_python_and_round_trip_through_toml(tmp_path):
    spec = rd.build_ragdoll(rd.humanoid(), mass_kg=80.0)
    assert spec.total_mass_kg == pytest.approx(80.0, rel=1e-4)
    thigh = spec.body("thigh_l")
    thigh.mass_kg = 12.5
    knee = spec.joint("shin_l")
    assert knee.kind == "hinge"
    knee.max_deg = 120.0
    if thigh.shape == "capsule":
        thigh.radius_m = 0.09
    again = rd.Spec.from_toml(spec.to_toml())
    assert again == spec
    assert again.body("thigh_l").mass_kg == 12.5
    assert again.joint("shin_l").max_deg == 120.0
    path = tmp_path / "hero.ragdoll.toml"
    spec.save(path)
    assert rd.Spec.load(path) == spec
    with pytest.raises(rd.BoundError) as e:
        knee.swing_deg = 30.0
    assert e.value.key == "swing_deg"


def test_a_ragdoll_built_with_roles_by_hand():
    c = rd.humanoid()
    spec = rd.build_ragdoll(c, roles={"thigh_l": "thigh_l", "thigh_r": "thigh_r"})
    assert spec.body("thigh_l").bone == "thigh_l"
    with pytest.raises(rd.RoleError) as e:
        rd.build_ragdoll(c, roles={"thigh_l": "no_such_bone"})
    assert e.value.key == "thigh_l" and "no_such_bone" in e.value.message


def test_errors_are_exceptions_with_their_place(tmp_path):
    with pytest.raises(rd.FileAccessError) as e:
        rd.load(tmp_path / "missing.glb")
    assert e.value.file.endswith("missing.glb")
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 zero\n}\n")
    with pytest.raises(rd.FileFormatError) as e:
        rd.load(bad)
    assert e.value.file.endswith("bad.bvh") and e.value.line == 4
    (tmp_path / "notes.txt").write_text("not a character")
    with pytest.raises(rd.FileFormatError) as e:
        rd.load(tmp_path / "notes.txt")
    with pytest.raises(rd.BoundError) as e:
        rd.World("warp")
    assert e.value.key == "backend"
    with pytest.raises(rd.BoundError) as e:
        rd.World("rigid", fps_of_doom=3)
    assert e.value.key == "fps_of_doom"
    with pytest.raises(rd.BoundError) as e:
        rd.World("rigid", substeps=0)
    assert e.value.key == "substeps"
    rd.World("rigid", gap_tolerance_m=0.001)
    rd.World("rigid", gap_tolerance_m=None)
    with pytest.raises(rd.BoundError) as e:
        rd.World("rigid", gap_tolerance_m=-0.001)
    assert e.value.key == "gap_tolerance_m"
    with pytest.raises(rd.BoundError) as e:
        rd.World("fast", gap_tolerance_m=0.001)
    assert e.value.key == "gap_tolerance_m" and "rigid backend" in str(e.value)
    # Each engine reads its own settings: another engine's would change nothing.
    with pytest.raises(rd.BoundError) as e:
        rd.World("rigid", fast_iterations=2)
    assert e.value.key == "fast_iterations" and "fast backend" in str(e.value)
    with pytest.raises(rd.BoundError) as e:
        rd.World("particle", keep_contacts=True)
    assert e.value.key == "keep_contacts" and "fast backend" in str(e.value)
    rd.World("fast", fast_iterations=2, freeze_joints=False, keep_contacts=True)
    with pytest.raises(rd.BoundError) as e:
        rd.World("fast", fast_iterations=9)
    assert e.value.key == "fast_iterations"
    names, parents, rest = humanoid_arrays()
    with pytest.raises(rd.SkeletonError) as e:
        rd.Character.from_arrays(names, [5] + parents[1:], rest)
    assert e.value.joint == names[0]
    spec = rd.build_ragdoll(rd.humanoid())
    spec.body("head").mass_kg = -1.0
    with pytest.raises(rd.SpecError) as e:
        spec.validate()
    assert "head" in e.value.place and "mass_kg" in e.value.place
    with pytest.raises(rd.SpecError):
        rd.World("rigid").add(rd.humanoid(), spec)
    world = rd.World("rigid")
    with pytest.raises(rd.BoundError) as e:
        world.add_blast(5.0, (1e9, 0, 0))
    assert e.value.key == "at"
    with pytest.raises(rd.BoundError) as e:
        world.add(rd.humanoid(), activate="blast")  # no animation to play first
    assert e.value.key == "activate"
    with pytest.raises(rd.BoundError):
        world.run(1.0)  # nothing in it
    world.add(rd.humanoid(), name="alice")
    for bad in ("alice", "Alice", "../x", ""):
        with pytest.raises(rd.BoundError) as e:
            world.add(rd.humanoid(), name=bad, at=(3, 0, 0))
        assert e.value.key == "name"
    assert len(world) == 1
    # Every one of them is a RagdollError.
    assert issubclass(rd.SpecError, rd.RagdollError)


def test_a_rust_panic_is_one_exception_and_python_goes_on():
    with pytest.raises(rd.InternalError) as e:
        _native._panic_for_tests("boom")
    assert "boom" in str(e.value)
    assert isinstance(e.value, rd.RagdollError)
    assert rd.humanoid().joint_names  # still alive


def test_progress_is_reported_and_false_cancels():
    w = rd.World("rigid")
    w.add(rd.humanoid())
    seen = []
    r = w.run(1.0, progress=lambda done, total: seen.append((done, total)))
    assert seen and seen[-1] == (60, 60)
    assert all(a[0] <= b[0] for a, b in zip(seen, seen[1:]))
    calls = []

    def stop(done, total):
        calls.append(done)
        return False

    with pytest.raises(rd.Cancelled):
        w.run(30.0, progress=stop)
    assert len(calls) == 1 and calls[0] < 1800
    assert r.frames == 31  # an earlier result is untouched


def test_ctrl_c_cancels_a_run():
    w = rd.World("rigid")
    for k in range(20):
        w.add(rd.humanoid(), at=(k * 1.0, 0, 0))
    threading.Timer(0.3, _thread.interrupt_main).start()
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        w.run(120.0)
    assert time.monotonic() - t0 < 10.0


def test_other_threads_run_while_it_steps():
    w = rd.World("rigid")
    for k in range(10):
        w.add(rd.humanoid(), at=(k * 1.0, 0, 0))
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t0 = time.monotonic()
    t.start()
    w.run(3.0)
    elapsed = time.monotonic() - t0
    stop.set()
    t.join()
    # Without the lock released, the counter would get a tick every 5 ms switch interval
    # at best; released, about one a millisecond.
    assert elapsed > 0.2 and len(ticks) > 0.3 * elapsed / 0.001, (len(ticks), elapsed)


def test_results_are_saved_as_gltf_bvh_and_json(tmp_path):
    import json

    w = rd.World("rigid")
    a = w.add(rd.humanoid(), name="a")
    w.add(rd.humanoid(), name="b", at=(2, 0, 0))
    w.add_projectile((0, 1.2, 5), target=(0, 1.2, 0), time_s=0.2)
    r = w.run(1.0)
    assert r.names == ["a", "b"]
    r.save(tmp_path / "both.glb")
    assert (tmp_path / "both.glb").read_bytes()[:4] == b"glTF"
    r.save(tmp_path / "a.bvh", handle=a)
    assert (tmp_path / "a.bvh").read_text().startswith("HIERARCHY")
    r.save(tmp_path / "report.json")
    assert json.loads((tmp_path / "report.json").read_text())["projectiles"][0]["character"] == 0
    with pytest.raises(rd.BoundError):
        r.save(tmp_path / "both.bvh")  # two characters, one BVH
    with pytest.raises(rd.BoundError):
        r.save(tmp_path / "out.fbx")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.bvh", "both.glb", "report.json"]
