"""The ragdoll's bodies as helper objects the user can see and edit: one empty per body in
a collection of its own, on the body's bone, sized as its shape, carrying its mass and its
joint's limits as custom properties (saved in the .blend). A bake reads them back."""

import contextlib

import bpy
from mathutils import Matrix, Quaternion, Vector

from . import rig

SPEC = "ragdoll_spec"
BODY = "ragdoll_body"
LIMITS = ("min_deg", "max_deg", "swing_deg", "twist_min_deg", "twist_max_deg")


def collection_name(arm):
    return f"Ragdoll: {arm.name}"


@contextlib.contextmanager
def original_action(arm):
    """While reading the user's animation: the user's own action plays, not a bake's."""
    ad = arm.animation_data
    if ad is None:
        yield
        return
    muted = []
    for t in ad.nla_tracks:
        if t.name == "Ragdoll" and not t.mute:
            t.mute = True
            muted.append(t)
    saved = ad.action
    original = None
    for t in ad.nla_tracks:
        if t.name == "Ragdoll: original action" and t.strips:
            original = t.strips[0].action
    if saved is None and original is not None:
        ad.action = original
    try:
        yield
    finally:
        ad.action = saved
        for t in muted:
            t.mute = False


def spec_of(arm, character, rd):
    """The armature's ragdoll: the one built and shown (with the user's edits of its helpers),
    else one built now."""
    text = arm.get(SPEC)
    if not text:
        return rd.build_ragdoll(character)
    spec = rd.Spec.from_toml(str(text), path=f"{arm.name} ragdoll")
    coll = bpy.data.collections.get(collection_name(arm))
    if coll is None:
        return spec
    u = rig.unit_scale(bpy.context.scene)
    for obj in coll.objects:
        name = obj.get(BODY)
        if name:
            edit_body(spec, spec.body(str(name)), obj, u)
    spec.validate()
    return spec


def changed(new, old):
    """Whether a value read back from a helper is the user's edit, not float noise from the
    round trip through Blender's matrices (which would change the simulation)."""
    return abs(new - old) > 1e-4 * max(abs(old), 1e-3)


def edit_body(spec, body, obj, u):
    """The user's edits of one helper, applied to its body and joint."""
    if "mass_kg" in obj and changed(float(obj["mass_kg"]), body.mass_kg):
        body.mass_kg = float(obj["mass_kg"])
    s = obj.matrix_world.to_scale() * u
    if body.shape == "capsule":
        r = 0.5 * (s.x + s.z)
        length = max(0.0, 2.0 * (s.y - r))
        if changed(r, body.radius_m) or changed(length, body.length_m):
            body.radius_m, body.length_m = r, length
    else:
        size = (2 * s.x, 2 * s.y, 2 * s.z)
        if any(changed(a, b) for a, b in zip(size, body.size_m)):
            body.size_m = size
    joint = next((j for j in spec.joints if j.child == body.name), None)
    if joint is None:
        return
    keys = {"hinge": ("min_deg", "max_deg"), "swing_twist": ("swing_deg",)}.get(joint.kind, ())
    for key in keys:
        if key in obj and changed(float(obj[key]), getattr(joint, key)):
            setattr(joint, key, float(obj[key]))
    if joint.kind == "swing_twist":
        t = joint.twist_deg
        new = (float(obj.get("twist_min_deg", t[0])), float(obj.get("twist_max_deg", t[1])))
        if changed(new[0], t[0]) or changed(new[1], t[1]):
            joint.twist_deg = new


def show(arm, character, spec):
    """Replaces the armature's helper collection with one empty per body of `spec`."""
    remove(arm)
    scene = bpy.context.scene
    u = rig.unit_scale(scene)
    coll = bpy.data.collections.new(collection_name(arm))
    scene.collection.children.link(coll)
    arm[SPEC] = spec.to_toml()
    joints = {j.child: j for j in spec.joints}
    for body in spec.bodies:
        bone = arm.data.bones.get(body.bone)
        if bone is None:
            continue
        empty = bpy.data.objects.new(f"{arm.name}: {body.name}", None)
        coll.objects.link(empty)
        if body.shape == "capsule":
            empty.empty_display_type = "SPHERE"
            half = Vector((body.radius_m, body.length_m / 2 + body.radius_m, body.radius_m))
        else:
            empty.empty_display_type = "CUBE"
            half = Vector(body.size_m) / 2
        empty.empty_display_size = 1.0
        empty.parent = arm
        empty.parent_type = "BONE"
        empty.parent_bone = bone.name
        # The body's frame in its bone's frame: the bone's axes are kept, metres to units.
        c = Vector(body.center_m) / u
        q = Quaternion((body.rotation[3], *body.rotation[:3]))
        pb = arm.pose.bones[bone.name]
        world = arm.matrix_world @ pb.matrix @ Matrix.LocRotScale(c, q, None)
        loc, rot, _ = world.decompose()
        empty.matrix_world = Matrix.LocRotScale(loc, rot, half / u)
        empty[BODY] = body.name
        empty["mass_kg"] = body.mass_kg
        j = joints.get(body.name)
        if j is not None and j.kind == "hinge":
            empty["min_deg"], empty["max_deg"] = j.min_deg, j.max_deg
        elif j is not None and j.kind == "swing_twist":
            empty["swing_deg"] = j.swing_deg
            empty["twist_min_deg"], empty["twist_max_deg"] = j.twist_deg
    return coll


def remove(arm):
    coll = bpy.data.collections.get(collection_name(arm))
    if coll is not None:
        for obj in list(coll.objects):
            bpy.data.objects.remove(obj)
        bpy.data.collections.remove(coll)
    if SPEC in arm:
        del arm[SPEC]
