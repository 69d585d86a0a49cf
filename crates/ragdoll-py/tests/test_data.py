"""Real third-party characters (../shared/data): read, recognised and simulated from Python
exactly as the command-line tool does it."""

import os
import pathlib
import shutil
import subprocess

import numpy as np
import pytest

import ragdoll_sim as rd


def cli():
    """The `ragdoll` binary: RAGDOLL_BIN, else cargo's release build, else PATH."""
    env = os.environ.get("RAGDOLL_BIN")
    if env:
        return env
    target = os.environ.get("CARGO_TARGET_DIR")
    roots = [pathlib.Path(target)] if target else []
    roots.append(pathlib.Path(__file__).resolve().parents[3] / "target")
    for root in roots:
        exe = root / "release" / "ragdoll"
        if exe.exists():
            return str(exe)
    return shutil.which("ragdoll")


def characters(data):
    files = sorted((data / "gltf").glob("*.gl*")) + sorted((data / "rigs").glob("*.*"))
    files += sorted((data / "bvh").glob("*.bvh"))[:3]
    return [f for f in files if f.suffix.lower() in (".glb", ".gltf", ".vrm", ".bvh")]


def test_cesium_man_is_a_humanoid_with_every_role(data):
    c = rd.load(data / "gltf" / "CesiumMan.glb")
    roles = c.roles
    assert roles.humanoid and len(roles) == 17 and not roles.missing
    assert c.mesh_count == 1 and len(c.clips) == 1
    assert 1.4 < c.height_m < 1.6


def test_the_fox_is_a_creature_and_says_why(data):
    roles = rd.load(data / "gltf" / "Fox.glb").roles
    assert not roles.humanoid
    assert roles.why
    assert set(roles.missing) >= {"pelvis", "thigh_l"}


def test_python_runs_are_the_command_line_runs(data, tmp_path):
    exe = cli()
    if exe is None:
        pytest.skip("needs the ragdoll command-line tool (cargo build --release)")
    for f in characters(data):
        want = tmp_path / f"{f.stem}.cli.bvh"
        subprocess.run([exe, "simulate", str(f), "--seconds", "1", "-o", str(want)],
                       check=True, capture_output=True)
        world = rd.World("rigid")
        h = world.add(rd.load(f))
        result = world.run(1.0)
        got = tmp_path / f"{f.stem}.py.bvh"
        result.save(got, handle=h)
        assert got.read_bytes() == want.read_bytes(), f.name
        assert np.isfinite(result.transforms(h)).all()


def test_a_scene_file_runs_as_the_command_line_runs_it(tmp_path):
    """No data needed: built-in humanoids. World.from_scene reads a scene file as
    `ragdoll simulate SCENE.toml` does, and gives the same files."""
    exe = cli()
    if exe is None:
        pytest.skip("needs the ragdoll command-line tool (cargo build --release)")
    scene = tmp_path / "scene.toml"
    scene.write_text(
        "duration_s = 1.5\nfps = 24\nbackend = \"fast\"\n"
        "[[character]]\nname = \"a\"\n"
        "[[character]]\nname = \"b\"\nposition = [1.5, 0.0, 0.0]\nfacing_deg = 90.0\n"
        "[[blast]]\ntnt_kg = 2.0\nposition = [0.7, 0.3, 1.5]\ntime_s = 0.2\n"
    )
    out = tmp_path / "cli"
    subprocess.run([exe, "simulate", str(scene), "-o", str(out)], check=True, capture_output=True)
    world = rd.World.from_scene(scene)
    assert len(world) == 2 and world.backend == "fast"
    result = world.run()
    assert result.frames == 37 and result.fps == 24
    for h, name in enumerate(result.names):
        result.save(tmp_path / f"{name}.bvh", handle=h)
        assert (tmp_path / f"{name}.bvh").read_bytes() == (out / f"{name}.bvh").read_bytes(), name
    result.save(tmp_path / "scene.glb")
    assert (tmp_path / "scene.glb").read_bytes() == (out / "scene.glb").read_bytes()


def test_a_bad_scene_file_names_its_line(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text("duration_s = 1.0\n[[character]]\nname = \"a\"\n[[blast]]\ntnt_kg = -2.0\nposition = [0, 0, 0]\n")
    with pytest.raises(rd.FileFormatError) as e:
        rd.World.from_scene(scene)
    assert e.value.file.endswith("bad.toml") and e.value.line == 5, (e.value.line, e.value.message)
