"""Benchmark (not a test): baking a character for 3 s in headless Blender, wall and CPU
time of `bpy.ops.ragdoll.bake()` alone (the engine, reading the rig and keying the action).

    RAGDOLL_BLENDER_ZIP=ragdoll-blender.zip ~/.cache/ragdoll-bpy-5.0.1/bin/python \\
        blender/bench_bake.py ../shared/data/gltf/CesiumMan.glb
"""

import os
import sys
import tempfile
import time

os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="ragdoll-bench-"))

import bpy  # noqa: E402


def main(path, repeat=5):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.extensions.package_install_files(
        filepath=os.environ["RAGDOLL_BLENDER_ZIP"], repo="user_default", enable_on_install=True
    )
    scene = bpy.context.scene
    bpy.ops.import_scene.gltf(filepath=path)
    arm = next(o for o in scene.objects if o.type == "ARMATURE")
    for o in scene.objects:
        o.select_set(o == arm)
    bpy.context.view_layer.objects.active = arm
    fps = scene.render.fps / scene.render.fps_base
    scene.frame_start, scene.frame_end = 1, 1 + round(3 * fps)
    best = None
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        assert bpy.ops.ragdoll.bake() == {"FINISHED"}, scene.ragdoll.status
        run = (time.perf_counter() - w0, time.process_time() - c0)
        best = run if best is None or run[0] < best[0] else best
    bones = len(arm.data.bones)
    print(f"{os.path.basename(path)}: 3 s bake at {fps:g} fps, {bones} bones: "
          f"{best[0]:.3f} s wall, {best[1]:.3f} s CPU (best of {repeat})")


if __name__ == "__main__":
    main(sys.argv[1])
