"""Renders the guide's picture with Blender itself: a character (a glTF file through
Blender's importer, or with `--figure` the rig the tests make in Blender), a charge added
and baked by the extension's operators, three frames of the bake side by side (Cycles on
the CPU, no display needed).

    RAGDOLL_BLENDER_ZIP=ragdoll-blender.zip ~/.cache/ragdoll-bpy-5.0.1/bin/python \\
        blender/render_guide.py --figure docs/blender_blast.png
"""

import os
import sys
import tempfile

os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="ragdoll-render-"))

import bpy  # noqa: E402
import numpy as np  # noqa: E402


def main(character, out):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert bpy.ops.extensions.package_install_files(
        filepath=os.environ["RAGDOLL_BLENDER_ZIP"], repo="user_default", enable_on_install=True
    ) == {"FINISHED"}
    scene = bpy.context.scene
    if character == "--figure":
        sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "tests"))
        from figure import make

        arm, skin = make()
        mat = bpy.data.materials.new("skin")
        mat.diffuse_color = (0.8, 0.45, 0.3, 1.0)
        skin.data.materials.append(mat)
        skin.modifiers.new("smooth", "SUBSURF").levels = 1
    else:
        bpy.ops.import_scene.gltf(filepath=character)
        arm = next(o for o in scene.objects if o.type == "ARMATURE")
    for o in scene.objects:
        o.select_set(o == arm)
        if o.type == "MESH" and not any(m.type == "ARMATURE" for m in o.modifiers):
            o.hide_render = True
    bpy.context.view_layer.objects.active = arm
    scene.render.fps = 30
    scene.frame_start, scene.frame_end = 1, 46
    scene.ragdoll.handover = "BLAST"
    scene.cursor.location = (0.8, -1.2, 0.0)
    bpy.ops.ragdoll.add_charge(tnt_kg=0.25)
    bpy.data.objects["Charge"].ragdoll.frame = 10
    assert bpy.ops.ragdoll.bake() == {"FINISHED"}, scene.ragdoll.status
    # A floor, a sun, a camera from the front and the side.
    bpy.ops.mesh.primitive_plane_add(size=40)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (0.7, 0.2, 0.6)
    sun.data.energy = 3.0
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    from mathutils import Vector

    cam.location = Vector((6.0, -7.0, 2.6))
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = (Vector((0.0, 1.5, 0.6)) - cam.location).to_track_quat("-Z", "Y")
    cam.data.lens = 60
    scene.camera = cam
    world = bpy.data.worlds.new("Sky")
    world.color = (0.6, 0.65, 0.7)
    scene.world = world
    r = scene.render
    r.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 16
    r.resolution_x, r.resolution_y = 480, 360
    tiles = []
    tmp = tempfile.mkdtemp()
    for f in (1, 16, 46):
        scene.frame_set(f)
        r.filepath = os.path.join(tmp, f"f{f}.png")
        bpy.ops.render.render(write_still=True)
        img = bpy.data.images.load(r.filepath)
        px = np.array(img.pixels[:]).reshape(img.size[1], img.size[0], 4)
        tiles.append(px)
    strip = np.concatenate(tiles, axis=1)
    h, w = strip.shape[:2]
    img = bpy.data.images.new("strip", w, h, alpha=True)
    img.pixels = strip.ravel()
    img.filepath_raw = out
    img.file_format = "PNG"
    img.save()
    print(out, scene.ragdoll.status)


if __name__ == "__main__":
    main(sys.argv[1], os.path.abspath(sys.argv[2]))
