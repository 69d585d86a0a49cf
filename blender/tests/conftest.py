"""Blender itself, headless (the `bpy` module), with the built extension installed into a
user folder of the test run's own: the tests drive the operators as a script would and
measure on Blender's evaluated data, not on ours."""

import os
import pathlib
import sys
import tempfile

import pytest

_home = tempfile.mkdtemp(prefix="ragdoll-blender-")
# Read when bpy starts: keep the user's own Blender settings and extensions out of it.
os.environ["BLENDER_USER_RESOURCES"] = _home

import bpy  # noqa: E402

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parents[1]


def extension_zip():
    z = os.environ.get("RAGDOLL_BLENDER_ZIP")
    return pathlib.Path(z) if z else None


def fresh_scene():
    """An empty scene with the extension installed and enabled."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    z = extension_zip()
    if z is None or not z.is_file():
        pytest.skip("needs the built extension: set RAGDOLL_BLENDER_ZIP (blender/build_extension.py)")
    r = bpy.ops.extensions.package_install_files(filepath=str(z), repo="user_default", enable_on_install=True)
    assert r == {"FINISHED"}
    assert hasattr(bpy.ops.ragdoll, "bake")
    return bpy.context.scene


@pytest.fixture
def scene():
    return fresh_scene()


def data_dir():
    env = os.environ.get("RAGDOLL_DATA")
    d = pathlib.Path(env) if env else REPO.parent / "shared" / "data"
    return d if d.is_dir() else None


@pytest.fixture
def data():
    d = data_dir()
    if d is None:
        pytest.skip("needs ../shared/data")
    return d


def extension():
    """The installed extension's modules, as Blender loaded them."""
    from bl_ext.user_default.ragdoll import bake, rig

    return bake, rig


sys.path.insert(0, str(HERE))
