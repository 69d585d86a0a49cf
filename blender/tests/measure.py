"""Measurements on Blender's own evaluated data (its depsgraph), with numpy: where the
skinned mesh is, how its edges stretch, where the pose bones are."""

import bpy
import numpy as np


def deformed_meshes(arm):
    return [o for o in bpy.context.scene.objects if o.type == "MESH"
            and any(m.type == "ARMATURE" and m.object == arm for m in o.modifiers)]


def evaluated_vertices(objs):
    dg = bpy.context.evaluated_depsgraph_get()
    out = []
    for o in objs:
        ev = o.evaluated_get(dg)
        me = ev.to_mesh()
        co = np.empty(len(me.vertices) * 3)
        me.vertices.foreach_get("co", co)
        mw = np.array(ev.matrix_world)
        out.append(co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3])
        ev.to_mesh_clear()
    return np.concatenate(out)


def edges(objs):
    out, base = [], 0
    for o in objs:
        e = np.empty(len(o.data.edges) * 2, dtype=np.int64)
        o.data.edges.foreach_get("vertices", e)
        out.append(e.reshape(-1, 2) + base)
        base += len(o.data.vertices)
    return np.concatenate(out)


def mesh_over_bake(arm, frames):
    """(lowest vertex over the frames as a share of the height, 99th percentile over the
    edges of each edge's largest stretch against the first frame, height): the measures
    the command-line tool's mesh check takes of a baked glTF."""
    scene = bpy.context.scene
    objs = deformed_meshes(arm)
    e = edges(objs)
    scene.frame_set(frames[0])
    v0 = evaluated_vertices(objs)
    h = v0[:, 2].max() - v0[:, 2].min()
    l0 = np.linalg.norm(v0[e[:, 0]] - v0[e[:, 1]], axis=1)
    ok = l0 > 1e-4
    worst = np.ones(int(ok.sum()))
    lowest = np.inf
    for f in frames:
        scene.frame_set(f)
        v = evaluated_vertices(objs)
        lowest = min(lowest, v[:, 2].min())
        l = np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1)[ok]
        worst = np.maximum(worst, l / l0[ok])
    return lowest / h, float(np.percentile(worst, 99)), h


def bones_against(arm, order, world_rows, rig):
    """Worst distance (m) and angle (degrees) between the evaluated pose bones and the
    engine's joint transforms, over every frame. A connected bone's head is held at its
    parent's tail by Blender whatever is keyed, so its distance is not counted: there the
    engine's own joint gap (millimetres) is closed."""
    scene = bpy.context.scene
    u = rig.unit_scale(scene)
    worst_d = worst_a = 0.0
    for k in range(world_rows.shape[0]):
        scene.frame_set(scene.frame_start + k)
        for i, b in enumerate(order):
            m = arm.matrix_world @ arm.pose.bones[b.name].matrix
            t, q = rig.from_engine(world_rows[k, i], u)
            if not b.use_connect:
                worst_d = max(worst_d, (m.to_translation() - t).length * u)
            worst_a = max(worst_a, rig.degrees(m.to_quaternion().rotation_difference(q)))
    return worst_d, worst_a
