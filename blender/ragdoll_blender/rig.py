"""The user's armature as the engine sees it, and back.

Blender is Z up in scene units; the engine is Y up in metres (glTF's axes: Blender's -Y,
its front, is the engine's +Z). A joint keeps its bone's own axes (Y along the bone, the
roll as the user set it): only the world around it changes, so the rotation that carries
a Blender world matrix into the engine is applied on the left.
"""

import math

import numpy as np
from mathutils import Matrix, Quaternion, Vector

# Engine coordinates of a Blender vector: (x, z, -y).
TO_ENGINE = Matrix(((1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)))
TO_ENGINE_Q = TO_ENGINE.to_quaternion()
FROM_ENGINE = TO_ENGINE.transposed()
FROM_ENGINE_Q = TO_ENGINE_Q.inverted()


class RigError(Exception):
    """Input the bake cannot use, in one sentence for Blender's info area."""


def unit_scale(scene):
    """Metres per Blender unit."""
    s = scene.unit_settings.scale_length
    return s if s > 0 else 1.0


def fps(scene):
    return scene.render.fps / (scene.render.fps_base or 1.0)


def uniform_scale(obj):
    s = obj.matrix_world.to_scale()
    if max(s) - min(s) > 1e-4 * max(abs(max(s)), 1e-9):
        raise RigError(
            f"{obj.name} has a non-uniform scale {tuple(round(v, 4) for v in s)}: "
            "apply it (Object > Apply > Scale) before ragdolling"
        )
    return s[0]


def bone_order(arm):
    """The armature's bones, parents before children (what the engine needs)."""
    order, seen = [], set()

    def visit(b):
        stack = [b]
        while stack:
            x = stack.pop()
            order.append(x)
            seen.add(x.name)
            stack.extend(reversed(x.children))

    for b in arm.data.bones:
        if b.parent is None:
            visit(b)
    return order


def to_engine(matrix, u):
    """A Blender world matrix (rotation and uniform scale) as engine translation and rotation."""
    loc, rot, _ = matrix.decompose()
    t = (TO_ENGINE @ loc) * u
    q = TO_ENGINE_Q @ rot
    return t, q


def to_engine_point(p, u):
    """A Blender world point in engine axes and metres."""
    return (TO_ENGINE @ p) * u


def from_engine(row, u):
    """One engine row (t, q xyzw, s) as a Blender world location and rotation."""
    t = FROM_ENGINE @ Vector(row[0:3]) / u
    q = FROM_ENGINE_Q @ Quaternion((row[6], row[3], row[4], row[5]))
    return t, q


def row(t, q, s=1.0):
    return [t.x, t.y, t.z, q.x, q.y, q.z, q.w, s, s, s]


def locals_from_worlds(worlds, parents):
    """Local rows from world (translation, rotation) pairs, in bone order."""
    out = []
    for (t, q), p in zip(worlds, parents):
        if p < 0:
            out.append(row(t, q))
            continue
        pt, pq = worlds[p]
        inv = pq.inverted()
        out.append(row(inv @ (t - pt), inv @ q))
    return out


def deforming_meshes(arm, scene):
    """Mesh objects an Armature modifier (or an armature parent) binds to `arm`."""
    out = []
    for obj in scene.objects:
        if obj.type != "MESH":
            continue
        mods = [m for m in obj.modifiers if m.type == "ARMATURE" and m.object == arm]
        if mods or (obj.parent == arm and obj.parent_type == "ARMATURE"):
            out.append(obj)
    return out


def mesh_arrays(objs, bone_index, u, warnings):
    """Positions (world, engine axes, metres), triangles, top-four joints and weights of
    every mesh in `objs`, merged into one skin."""
    positions, tris, joints, weights = [], [], [], []
    base = 0
    for obj in objs:
        me = obj.data
        n = len(me.vertices)
        if n == 0:
            continue
        co = np.empty(n * 3)
        me.vertices.foreach_get("co", co)
        co = co.reshape(n, 3)
        mw = np.array(obj.matrix_world)
        world = co @ mw[:3, :3].T + mw[:3, 3]
        eng = world @ np.array(TO_ENGINE).T * u
        groups = {g.index: bone_index.get(g.name) for g in obj.vertex_groups}
        j = np.zeros((n, 4), dtype=np.int64)
        w = np.zeros((n, 4))
        unweighted = 0
        for v in me.vertices:
            ws = [(g.weight, groups.get(g.group)) for g in v.groups]
            ws = sorted((x for x in ws if x[1] is not None and x[0] > 0), reverse=True)[:4]
            if not ws:
                unweighted += 1
                continue
            # Blender's Armature modifier divides by the sum of a vertex's weights: so do we
            # (over the four kept), rather than have the engine warn of unnormalised weights.
            total = sum(wt for wt, _ in ws)
            for k, (wt, jj) in enumerate(ws):
                j[v.index, k] = jj
                w[v.index, k] = wt / total
        if unweighted == n:
            warnings.append(f"{obj.name} has no weights on the armature's bones; it is left out")
            continue
        if unweighted:
            warnings.append(
                f"{obj.name}: {unweighted} of {n} vertices have no weight on a bone and follow the root"
            )
        me.calc_loop_triangles()
        t = np.empty(len(me.loop_triangles) * 3, dtype=np.int64)
        me.loop_triangles.foreach_get("vertices", t)
        positions.append(eng)
        tris.append(t.reshape(-1, 3) + base)
        joints.append(j)
        weights.append(w)
        base += n
    if not positions:
        return None
    return {
        "positions": np.concatenate(positions),
        "triangles": np.concatenate(tris),
        "joints": np.concatenate(joints),
        "weights": np.concatenate(weights),
    }


def pose_worlds(arm, order, scale, u):
    """Every bone's current posed world transform, engine axes."""
    mw = arm.matrix_world
    out = []
    for b in order:
        m = mw @ arm.pose.bones[b.name].matrix
        out.append(to_engine(m, u))
    return out


def character_arrays(arm, scene, frames=None):
    """What `Character.from_arrays` takes for `arm`, with the warnings to show.

    `frames`: scene frames whose pose becomes the character's animation (the action plays
    until the hand-over), or None for none.
    """
    if arm.type != "ARMATURE":
        raise RigError(f"{arm.name} is not an armature")
    if len(arm.data.bones) == 0:
        raise RigError(f"{arm.name} has no bones")
    u = unit_scale(scene)
    s = uniform_scale(arm)
    order = bone_order(arm)
    index = {b.name: i for i, b in enumerate(order)}
    parents = [index[b.parent.name] if b.parent else -1 for b in order]
    mw = arm.matrix_world
    rest = [to_engine(mw @ b.matrix_local, u) for b in order]
    tips = [[0.0, b.length * s * u, 0.0] for b in order]
    warnings = []
    deform = {b.name: i for i, b in enumerate(order) if b.use_deform}
    mesh = mesh_arrays(deforming_meshes(arm, scene), deform, u, warnings)
    clip = None
    if frames:
        now = scene.frame_current
        clip = []
        try:
            for f in frames:
                scene.frame_set(f)
                clip.append(locals_from_worlds(pose_worlds(arm, order, s, u), parents))
        finally:
            scene.frame_set(now)
    return {
        "names": [b.name for b in order],
        "parents": parents,
        "rest_local": np.array(locals_from_worlds(rest, parents)),
        # A leaf bone's tail says where it ends only on a rig without skin: importers make
        # up tails (Blender's glTF importer gave a 21 cm hand's fingertips 10 cm bones, and
        # the hand twenty bodies instead of the one its rigid skin makes); the skin knows.
        "tips": np.array(tips) if mesh is None else None,
        "mesh": mesh,
        "frames": None if clip is None else np.array(clip),
        "order": order,
        "warnings": warnings,
    }


def basis_matrices(arm, order, world_rows, scene):
    """Pose-bone basis matrices (the values keyed on the user's rig) for one frame of engine
    world rows, by the standard rest-relative formula: the rest pose and bone rolls are the
    user's own."""
    u = unit_scale(scene)
    s = uniform_scale(arm)
    inv_obj = arm.matrix_world.inverted()
    pose_arm = {}
    out = {}
    for b, r in zip(order, world_rows):
        t, q = from_engine(r, u)
        m = inv_obj @ Matrix.LocRotScale(t, q, Vector((s, s, s)))
        # Armature space holds no object scale: take it out again.
        m = Matrix.LocRotScale(m.to_translation(), m.to_quaternion(), None)
        pose_arm[b.name] = m
        if b.parent is None:
            out[b.name] = b.matrix_local.inverted() @ m
        else:
            rel_rest = b.parent.matrix_local.inverted() @ b.matrix_local
            rel_pose = pose_arm[b.parent.name].inverted() @ m
            out[b.name] = rel_rest.inverted() @ rel_pose
    return out


def degrees(q):
    return math.degrees(2 * math.acos(min(1.0, abs(q.w))))
