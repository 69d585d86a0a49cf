"""From the scene to the engine and back: the selected armatures become one world (a crowd
when there are several), charges and projectiles its events; the result is keyed on each
armature as a new action in its own NLA track, the user's action kept beneath it."""

import json
import re

import bpy
import numpy as np
from mathutils import Vector

from . import helpers, rig

# The last bake's engine result and its armatures ([(armature, bones in engine order,
# handle)]), for scripts that want the numbers behind the keys (`result.report`,
# `result.transforms(handle)`): Blender's undo and file I/O never hold native objects.
LAST = {"result": None, "parts": []}

TRACK = "Ragdoll"
ORIGINAL_TRACK = "Ragdoll: original action"
# Custom properties the extension leaves on an armature.
MUTED = "ragdoll_muted_constraints"
PINS = "ragdoll_pins"


def selected_armatures(context):
    """The armatures to ragdoll: the crowd collection's when one is set, else the selected
    ones (or the active one)."""
    crowd = context.scene.ragdoll.crowd
    if crowd is not None:
        arms = [o for o in crowd.all_objects if o.type == "ARMATURE"]
        if not arms:
            raise rig.RigError(f"the crowd collection {crowd.name} holds no armature")
        return arms
    arms = [o for o in context.selected_objects if o.type == "ARMATURE"]
    active = context.active_object
    if not arms and active is not None and active.type == "ARMATURE":
        arms = [active]
    if not arms:
        raise rig.RigError("select an armature (or several, for a crowd) first")
    return arms


def safe_name(name):
    """An object's name as a character's: it names files, so letters, digits, '_', '-' and
    '.' only (a clash is resolved by the world, with _2, _3...)."""
    safe = re.sub(r"[^\w.-]", "_", name).lstrip(".")[:64]
    return safe or "armature"


def events(scene, u, fps):
    """Charges and projectiles: every empty of the scene that is one."""
    start = scene.frame_start
    blasts, shots = [], []
    for obj in scene.objects:
        kind = obj.ragdoll.kind if hasattr(obj, "ragdoll") else "NONE"
        if kind == "NONE":
            continue
        at, _ = rig.to_engine(obj.matrix_world, u)
        time_s = max(0.0, (obj.ragdoll.frame - start) / fps)
        if kind == "CHARGE":
            blasts.append(dict(tnt_kg=obj.ragdoll.tnt_kg, at=tuple(at), time_s=time_s, air=obj.ragdoll.air))
        else:
            z = obj.matrix_world.to_3x3() @ Vector((0.0, 0.0, 1.0))
            d = rig.TO_ENGINE @ z
            shots.append(dict(origin=tuple(at), direction=tuple(d), mass_kg=obj.ragdoll.mass_kg,
                              speed_mps=obj.ragdoll.speed_mps, time_s=time_s))
    return blasts, shots


def prepare(context, rd):
    """The world for the selected armatures, and what writing the result back needs."""
    scene = context.scene
    props = scene.ragdoll
    u, fps = rig.unit_scale(scene), rig.fps(scene)
    arms = selected_armatures(context)
    start, end = scene.frame_start, scene.frame_end
    if end <= start:
        raise rig.RigError("the scene's frame range is empty: set an end frame after the start")
    seconds = (end - start) / fps
    # The ragdoll starts in the pose the user sees at the start frame; the action's other
    # frames are read only when it plays on (a hand-over later, or motors following it).
    plays = props.handover != "START" or props.motors > 0
    frames = range(start, end + 1) if plays else [start]
    world = rd.World(props.backend)
    parts, warnings = [], []
    for arm in arms:
        # The bake's own action must not feed the next one: read the user's animation.
        with helpers.original_action(arm):
            a = rig.character_arrays(arm, scene, frames)
        warnings += a.pop("warnings")
        order = a.pop("order")
        c = rd.Character.from_arrays(a["names"], a["parents"], a["rest_local"], mesh=a["mesh"],
                                     frames=a["frames"], fps=fps, name=safe_name(arm.name), tips=a["tips"])
        warnings += c.warnings
        spec = helpers.spec_of(arm, c, rd)
        activate = {"START": "start", "BLAST": "blast", "CONTACT": "contact"}.get(props.handover)
        if props.handover == "FRAME":
            activate = max(0.0, (props.handover_frame - start) / fps)
        kwargs = dict(activate=activate)
        if props.motors > 0:
            kwargs["powered"] = {"strength": props.motors, "root_on_clip": False}
        h = world.add(c, spec, **kwargs)
        for bone in str(arm.get(PINS, "")).split(","):
            if bone and bone in arm.pose.bones:
                head = arm.matrix_world @ arm.pose.bones[bone].head
                world.add_pin(h, bone, tuple(rig.to_engine_point(head, u)))
        parts.append((arm, order, h))
    blasts, shots = events(scene, u, fps)
    for b in blasts:
        world.add_blast(**b)
    for s in shots:
        world.add_projectile(**s)
    return world, seconds, fps, parts, warnings


def keyed_paths(pb):
    if pb.rotation_mode == "QUATERNION":
        return "rotation_quaternion", 4
    if pb.rotation_mode == "AXIS_ANGLE":
        return "rotation_axis_angle", 4
    return "rotation_euler", 3


def write_action(arm, order, world_rows, scene):
    """Keys every frame of `world_rows` (frames, joints, 10) on `arm`'s pose bones (location,
    rotation in the bone's own rotation mode, and scale) as a new action in the top NLA
    track; the user's action moves to a track beneath it."""
    start = scene.frame_start
    n = world_rows.shape[0]
    values = {b.name: ([], []) for b in order}
    prev = {}
    for f in range(n):
        basis = rig.basis_matrices(arm, order, world_rows[f], scene)
        for b in order:
            pb = arm.pose.bones[b.name]
            m = basis[b.name]
            loc, q = m.to_translation(), m.to_quaternion()
            if pb.rotation_mode == "QUATERNION":
                if b.name in prev and prev[b.name].dot(q) < 0:
                    q.negate()
                prev[b.name] = q
                rot = list(q)
            elif pb.rotation_mode == "AXIS_ANGLE":
                axis, angle = q.to_axis_angle()
                rot = [angle, *axis]
            else:
                e = q.to_euler(pb.rotation_mode, prev.get(b.name))
                prev[b.name] = e
                rot = list(e)
            values[b.name][0].append(list(loc))
            values[b.name][1].append(rot)
    clear_bake(arm)
    ad = arm.animation_data_create()
    original = ad.action
    if original is not None:
        track = ad.nla_tracks.new()
        track.name = ORIGINAL_TRACK
        strip = track.strips.new(original.name, int(original.frame_range[0]), original)
        strip.name = original.name
        ad.action = None
    action = bpy.data.actions.new(f"{arm.name} ragdoll")
    action["ragdoll_bake"] = True
    if original is not None:
        action["ragdoll_original"] = original.name
    ad.action = action
    frames = np.arange(start, start + n, dtype=np.float64)
    for b in order:
        pb = arm.pose.bones[b.name]
        path, width = keyed_paths(pb)
        base = f'pose.bones["{bpy.utils.escape_identifier(b.name)}"]'
        locs, rots = (np.array(v) for v in values[b.name])
        # Scale is keyed too (the rest's): the user's action beneath would otherwise still
        # scale the bones its keys scale.
        ones = np.ones((n, 3))
        for prop, data, k in (("location", locs, 3), (path, rots, width), ("scale", ones, 3)):
            for i in range(k):
                fc = fcurve(action, arm, f"{base}.{prop}", i, b.name)
                fc.keyframe_points.add(n)
                fc.keyframe_points.foreach_set("co", np.column_stack([frames, data[:, i]]).ravel())
                for kp in fc.keyframe_points:
                    kp.interpolation = "LINEAR"
                fc.update()
    ad.action = None
    track = ad.nla_tracks.new()
    track.name = TRACK
    strip = track.strips.new(action.name, start, action)
    strip.name = action.name
    if hasattr(strip, "action_slot") and len(getattr(action, "slots", [])) > 0:
        strip.action_slot = action.slots[0]
    mute_constraints(arm)
    return action


def fcurve(action, arm, path, index, group):
    """An F-curve of `action` for `arm`: through its slot on Blender 4.4 and later, on the
    action itself before."""
    if hasattr(action, "fcurve_ensure_for_datablock"):
        try:
            return action.fcurve_ensure_for_datablock(arm, path, index=index, group_name=group)
        except TypeError:  # 4.4 and 4.5: no group_name
            return action.fcurve_ensure_for_datablock(arm, path, index=index)
    return action.fcurves.new(path, index=index, action_group=group)


def mute_constraints(arm):
    """Bone constraints would override the baked pose: they are muted, and restored by
    Clear. Returns how many."""
    muted = []
    for pb in arm.pose.bones:
        for c in pb.constraints:
            if not c.mute:
                c.mute = True
                muted.append(f"{pb.name}\t{c.name}")
    if muted:
        arm[MUTED] = "\n".join(muted)
    return len(muted)


def clear_bake(arm):
    """Removes the bake from `arm`: its track and action, the muted constraints unmuted and
    the user's action made active again."""
    ad = arm.animation_data
    for line in str(arm.get(MUTED, "")).splitlines():
        bone, _, name = line.partition("\t")
        pb = arm.pose.bones.get(bone)
        if pb is not None and name in pb.constraints:
            pb.constraints[name].mute = False
    if MUTED in arm:
        del arm[MUTED]
    if ad is None:
        return
    for track in list(ad.nla_tracks):
        if track.name == TRACK:
            for s in track.strips:
                if s.action is not None and s.action.get("ragdoll_bake"):
                    bpy.data.actions.remove(s.action)
            ad.nla_tracks.remove(track)
    for track in list(ad.nla_tracks):
        if track.name == ORIGINAL_TRACK:
            if track.strips and ad.action is None:
                ad.action = track.strips[0].action
            ad.nla_tracks.remove(track)
    if ad.action is not None and ad.action.get("ragdoll_bake"):
        bpy.data.actions.remove(ad.action)


def store_report(scene, result, warnings, parts):
    LAST["result"], LAST["parts"] = result, list(parts)
    report = result.report
    report["warnings"] = warnings
    scene.ragdoll.report = json.dumps(report)
    return report


def summary(report):
    """Peak speed per character, and the peak loads of the blast per part."""
    lines = []
    for c in report.get("characters", []):
        lines.append(f"{c['name']}: peak speed {c['max_speed_mps']:.1f} m/s, {c['total_mass_kg']:.0f} kg")
    for b in report.get("blasts", []):
        parts = sorted(b["parts"], key=lambda p: -p["impulse_ns"])[:6]
        for p in parts:
            lines.append(f"  {p['body']}: {p['impulse_ns']:.1f} N·s, {p['peak_pressure_kpa']:.0f} kPa")
    return lines
