"""A character made in Blender for a bare clone: a humanoid armature (Z up, facing -Y,
names of its own) and a skin of tubes around its bones, each tube's first ring shared
half with the parent bone, bound with an Armature modifier."""

import math

import bpy

# name, parent, head, tail (metres, Blender axes), tube radius
BONES = [
    ("hips", None, (0, 0, 0.95), (0, 0, 1.08), 0.13),
    ("belly", "hips", (0, 0, 1.08), (0, 0, 1.25), 0.12),
    ("ribs", "belly", (0, 0, 1.25), (0, 0, 1.45), 0.13),
    ("neck", "ribs", (0, 0, 1.45), (0, 0, 1.55), 0.05),
    ("head", "neck", (0, 0, 1.55), (0, 0, 1.77), 0.09),
]
for side, x in (("L", 1), ("R", -1)):
    BONES += [
        (f"upperarm.{side}", "ribs", (0.18 * x, 0, 1.42), (0.45 * x, 0, 1.42), 0.05),
        (f"lowerarm.{side}", f"upperarm.{side}", (0.45 * x, 0, 1.42), (0.70 * x, 0, 1.42), 0.04),
        (f"hand.{side}", f"lowerarm.{side}", (0.70 * x, 0, 1.42), (0.82 * x, 0, 1.42), 0.035),
        (f"thigh.{side}", "hips", (0.1 * x, 0, 0.92), (0.1 * x, 0, 0.50), 0.075),
        (f"shin.{side}", f"thigh.{side}", (0.1 * x, 0, 0.50), (0.1 * x, 0, 0.09), 0.055),
        (f"foot.{side}", f"shin.{side}", (0.1 * x, 0, 0.09), (0.1 * x, -0.16, 0.02), 0.04),
    ]


def make(name="Figure", at=(0.0, 0.0, 0.0), scale=1.0):
    """The armature object (selected and active) and its mesh object."""
    scene = bpy.context.scene
    data = bpy.data.armatures.new(name)
    arm = bpy.data.objects.new(name, data)
    scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    for bname, parent, head, tail, _ in BONES:
        b = data.edit_bones.new(bname)
        b.head = [v * scale for v in head]
        b.tail = [v * scale for v in tail]
        if parent:
            b.parent = data.edit_bones[parent]
            b.use_connect = tuple(data.edit_bones[parent].tail) == tuple(b.head)
    bpy.ops.object.mode_set(mode="OBJECT")
    verts, faces, groups = [], [], []
    ring = 8
    for bname, parent, head, tail, radius in BONES:
        h = [v * scale for v in head]
        t = [v * scale for v in tail]
        d = [b - a for a, b in zip(h, t)]
        length = math.sqrt(sum(c * c for c in d))
        axis = [c / length for c in d]
        # Two directions across the bone.
        ref = (0, 0, 1) if abs(axis[2]) < 0.9 else (1, 0, 0)
        u = cross(axis, ref)
        u = [c / math.sqrt(sum(k * k for k in u)) for c in u]
        w = cross(axis, u)
        first = len(verts)
        for k in range(4):
            s = k / 3
            for j in range(ring):
                a = 2 * math.pi * j / ring
                p = [h[i] + d[i] * s + scale * radius * (math.cos(a) * u[i] + math.sin(a) * w[i]) for i in range(3)]
                verts.append(p)
                groups.append([(bname, 0.5), (parent, 0.5)] if (k == 0 and parent) else [(bname, 1.0)])
        for k in range(3):
            for j in range(ring):
                a, b = first + k * ring + j, first + k * ring + (j + 1) % ring
                faces.append((a, b, b + ring, a + ring))
    me = bpy.data.meshes.new(f"{name} skin")
    me.from_pydata(verts, [], faces)
    skin = bpy.data.objects.new(f"{name} skin", me)
    scene.collection.objects.link(skin)
    for bname, *_ in BONES:
        skin.vertex_groups.new(name=bname)
    for i, g in enumerate(groups):
        for bname, weight in g:
            skin.vertex_groups[bname].add([i], weight, "REPLACE")
    mod = skin.modifiers.new("Armature", "ARMATURE")
    mod.object = arm
    skin.parent = arm
    arm.location = at
    for o in scene.objects:
        o.select_set(False)
    arm.select_set(True)
    bpy.context.view_layer.objects.active = arm
    return arm, skin


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
