"""Ragdoll for Blender: the user's own armature becomes a ragdoll in place; charges and
projectiles are empties in the scene; a bake keys what happens on the same armature as a
new action, the user's own action kept beneath it.

Every operator runs to completion when called from a script or in the background, so
farm jobs and tests drive it; with a window, the bake runs beside the interface (progress
in the status bar, Esc cancels). Bad input is one sentence in the info area, never a
traceback.
"""

import threading
import traceback

import bpy

from . import bake, helpers, props, rig


def engine():
    """The native engine, imported when first needed (Blender cannot unload it: an update
    of the extension takes effect after a restart)."""
    import ragdoll_sim

    return ragdoll_sim


def say(op, context, level, message):
    context.scene.ragdoll.status = message
    op.report({level}, message)


def guarded(fn):
    """An operator body whose errors become one sentence in the info area."""

    def run(self, context, *args):
        try:
            return fn(self, context, *args)
        except rig.RigError as e:
            say(self, context, "ERROR", str(e))
        except Exception as e:  # noqa: BLE001 - the user sees one sentence, never a traceback
            rd = engine()
            if isinstance(e, rd.RagdollError):
                say(self, context, "ERROR", str(e))
            else:
                traceback.print_exc()
                say(self, context, "ERROR", f"ragdoll: internal error: {e}")
        return {"CANCELLED"}

    return run


class RAGDOLL_OT_build(bpy.types.Operator):
    """Find the roles of the selected armatures' bones and show their ragdolls' bodies"""

    bl_idname = "ragdoll.build"
    bl_label = "Build Ragdoll"
    bl_options = {"REGISTER", "UNDO"}

    @guarded
    def execute(self, context):
        rd = engine()
        lines = []
        for arm in bake.selected_armatures(context):
            a = rig.character_arrays(arm, context.scene)
            c = rd.Character.from_arrays(a["names"], a["parents"], a["rest_local"], mesh=a["mesh"],
                                         name=arm.name, tips=a["tips"])
            spec = rd.build_ragdoll(c)
            helpers.show(arm, c, spec)
            roles = c.roles
            missing = "; ".join(f"{r}: {why}" for r, why in roles.missing.items())
            lines.append(f"{arm.name}: {len(spec.bodies)} bodies, {spec.total_mass_kg:.0f} kg; {roles.why}"
                         + (f" Missing: {missing}" if roles.humanoid and missing else ""))
            for w in a["warnings"] + c.warnings:
                self.report({"WARNING"}, w)
        say(self, context, "INFO", " | ".join(lines))
        return {"FINISHED"}


class RAGDOLL_OT_add_charge(bpy.types.Operator):
    """Add an explosive charge at the 3D cursor"""

    bl_idname = "ragdoll.add_charge"
    bl_label = "Add Charge"
    bl_options = {"REGISTER", "UNDO"}

    tnt_kg: bpy.props.FloatProperty(name="TNT (kg)", min=0.0001, max=100000.0, default=5.0)
    air: bpy.props.BoolProperty(name="In the Air", default=False)

    @guarded
    def execute(self, context):
        obj = bpy.data.objects.new("Charge", None)
        obj.empty_display_type = "SPHERE"
        obj.empty_display_size = 0.2
        obj.location = context.scene.cursor.location
        context.scene.collection.objects.link(obj)
        obj.ragdoll.kind = "CHARGE"
        obj.ragdoll.tnt_kg = self.tnt_kg
        obj.ragdoll.air = self.air
        obj.ragdoll.frame = context.scene.frame_current
        say(self, context, "INFO", f"added {obj.name}: {self.tnt_kg} kg of TNT at frame {obj.ragdoll.frame}")
        return {"FINISHED"}


class RAGDOLL_OT_add_projectile(bpy.types.Operator):
    """Add a projectile at the 3D cursor, flying along its Z axis (toward the active armature)"""

    bl_idname = "ragdoll.add_projectile"
    bl_label = "Add Projectile"
    bl_options = {"REGISTER", "UNDO"}

    mass_kg: bpy.props.FloatProperty(name="Mass (kg)", min=0.0001, max=1000.0, default=0.008)
    speed_mps: bpy.props.FloatProperty(name="Speed (m/s)", min=0.0, max=10000.0, default=360.0)

    @guarded
    def execute(self, context):
        from mathutils import Vector

        obj = bpy.data.objects.new("Projectile", None)
        obj.empty_display_type = "SINGLE_ARROW"
        obj.empty_display_size = 0.3
        at = context.scene.cursor.location.copy()
        obj.location = at
        target = context.active_object
        if target is not None and target.type == "ARMATURE":
            aim = target.matrix_world.translation.copy()
            aim.z = at.z
            d = aim - at
            if d.length > 1e-6:
                obj.rotation_mode = "QUATERNION"
                obj.rotation_quaternion = Vector((0, 0, 1)).rotation_difference(d)
        context.scene.collection.objects.link(obj)
        obj.ragdoll.kind = "PROJECTILE"
        obj.ragdoll.mass_kg = self.mass_kg
        obj.ragdoll.speed_mps = self.speed_mps
        obj.ragdoll.frame = context.scene.frame_current
        say(self, context, "INFO", f"added {obj.name}: {self.mass_kg} kg at {self.speed_mps} m/s")
        return {"FINISHED"}


class RAGDOLL_OT_pin_selected(bpy.types.Operator):
    """Pin the selected pose bones where they are for the whole bake (again to unpin)"""

    bl_idname = "ragdoll.pin_selected"
    bl_label = "Pin Selected Bones"
    bl_options = {"REGISTER", "UNDO"}

    @guarded
    def execute(self, context):
        arm = context.active_object
        if arm is None or arm.type != "ARMATURE":
            raise rig.RigError("pins are set on the active armature's selected bones")
        chosen = {pb.name for pb in (context.selected_pose_bones or [])}
        pins = set(filter(None, str(arm.get(bake.PINS, "")).split(",")))
        pins ^= chosen
        arm[bake.PINS] = ",".join(sorted(pins))
        say(self, context, "INFO", f"pinned: {', '.join(sorted(pins)) or 'none'}")
        return {"FINISHED"}


class RAGDOLL_OT_bake(bpy.types.Operator):
    """Simulate the selected armatures (a crowd when several) with the scene's charges and
    projectiles, and key the result on them as a new action"""

    bl_idname = "ragdoll.bake"
    bl_label = "Bake Ragdoll"
    bl_options = {"REGISTER", "UNDO"}

    _thread = None
    _timer = None

    @guarded
    def execute(self, context):
        world, seconds, fps, parts, warnings = bake.prepare(context, engine())
        result = world.run(seconds, fps=fps)
        return self.finish(context, result, parts, warnings)

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        return self.start(context)

    @guarded
    def start(self, context):
        world, seconds, fps, parts, warnings = bake.prepare(context, engine())
        self._parts, self._warnings = parts, warnings
        self._cancel, self._done, self._total = False, 0, 1
        self._result = self._error = None

        def progress(done, total):
            self._done, self._total = done, total
            return not self._cancel

        def work():
            try:
                self._result = world.run(seconds, fps=fps, progress=progress)
            except BaseException as e:  # noqa: BLE001 - handed to the main thread
                self._error = e

        self._thread = threading.Thread(target=work, daemon=True)
        self._thread.start()
        wm = context.window_manager
        wm.progress_begin(0, 100)
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC":
            self._cancel = True
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            # The interface stays usable while the engine steps in its thread.
            return {"PASS_THROUGH"}
        if self._thread.is_alive():
            context.window_manager.progress_update(int(100 * self._done / max(1, self._total)))
            return {"RUNNING_MODAL"}
        return self.end(context)

    @guarded
    def end(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if self._error is not None:
            if isinstance(self._error, engine().Cancelled):
                say(self, context, "WARNING", "bake cancelled; nothing was changed")
                return {"CANCELLED"}
            raise self._error
        return self.finish(context, self._result, self._parts, self._warnings)

    def finish(self, context, result, parts, warnings):
        scene = context.scene
        muted = 0
        for arm, order, h in parts:
            bake.write_action(arm, order, result.transforms(h, space="world"), scene)
            muted += len(str(arm.get(bake.MUTED, "")).splitlines())
        if muted:
            warnings.append(f"{muted} bone constraints were muted so they do not override the "
                            "ragdoll; Clear unmutes them")
        report = bake.store_report(scene, result, warnings, parts)
        for w in warnings:
            self.report({"WARNING"}, w)
        speed = max((c["max_speed_mps"] for c in report["characters"]), default=0.0)
        say(self, context, "INFO", f"baked {len(parts)} armature(s), {result.frames} frames; "
            f"peak speed {speed:.1f} m/s")
        return {"FINISHED"}


class RAGDOLL_OT_clear(bpy.types.Operator):
    """Remove the selected armatures' bakes and ragdoll helpers, restoring their actions"""

    bl_idname = "ragdoll.clear"
    bl_label = "Clear Ragdoll"
    bl_options = {"REGISTER", "UNDO"}

    @guarded
    def execute(self, context):
        arms = bake.selected_armatures(context)
        for arm in arms:
            bake.clear_bake(arm)
            helpers.remove(arm)
        context.scene.ragdoll.report = ""
        say(self, context, "INFO", f"cleared {', '.join(a.name for a in arms)}")
        return {"FINISHED"}


class RAGDOLL_PT_panel(bpy.types.Panel):
    bl_label = "Ragdoll"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Ragdoll"

    def draw(self, context):
        import json

        p = context.scene.ragdoll
        col = self.layout.column()
        col.prop(p, "backend")
        col.prop(p, "crowd")
        col.prop(p, "handover")
        if p.handover == "FRAME":
            col.prop(p, "handover_frame")
        col.prop(p, "motors", slider=True)
        col.operator("ragdoll.build")
        col.operator("ragdoll.pin_selected")
        row = col.row(align=True)
        row.operator("ragdoll.add_charge")
        row.operator("ragdoll.add_projectile")
        for obj in context.scene.objects:
            if hasattr(obj, "ragdoll") and obj.ragdoll.kind != "NONE":
                box = col.box()
                box.label(text=obj.name, icon="FORCE_FORCE" if obj.ragdoll.kind == "CHARGE" else "EMPTY_SINGLE_ARROW")
                if obj.ragdoll.kind == "CHARGE":
                    box.prop(obj.ragdoll, "tnt_kg")
                    box.prop(obj.ragdoll, "air")
                else:
                    box.prop(obj.ragdoll, "mass_kg")
                    box.prop(obj.ragdoll, "speed_mps")
                box.prop(obj.ragdoll, "frame")
        row = col.row(align=True)
        row.scale_y = 1.4
        row.operator("ragdoll.bake", icon="PLAY")
        row.operator("ragdoll.clear", icon="X")
        if p.status:
            col.label(text=p.status[:120])
        if p.report:
            box = col.box()
            for line in bake.summary(json.loads(p.report)):
                box.label(text=line)


CLASSES = (
    RAGDOLL_OT_build,
    RAGDOLL_OT_add_charge,
    RAGDOLL_OT_add_projectile,
    RAGDOLL_OT_pin_selected,
    RAGDOLL_OT_bake,
    RAGDOLL_OT_clear,
    RAGDOLL_PT_panel,
)


def register():
    props.register()
    for c in CLASSES:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
    props.unregister()
