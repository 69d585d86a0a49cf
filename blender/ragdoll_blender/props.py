"""The extension's settings: a scene's (backend, hand-over, motors, the last report) and an
object's (a charge's or a projectile's values), saved in the .blend file."""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty


class RagdollSceneProps(bpy.types.PropertyGroup):
    backend: EnumProperty(
        name="Backend",
        items=[
            ("rigid", "Rigid", "rapier's rigid bodies: the reference"),
            ("fast", "Fast", "Our solver built for ragdolls and crowds"),
            ("particle", "Particle", "Our position-based particle ragdoll, for creatures"),
        ],
        default="rigid",
    )
    handover: EnumProperty(
        name="Hand-over",
        description="When physics takes over from the current action",
        items=[
            ("START", "Start", "Physical from the first frame"),
            ("FRAME", "Frame", "The action plays until the hand-over frame"),
            ("BLAST", "Blast", "The action plays until the first blast reaches the character"),
            ("CONTACT", "Contact", "The action plays until something other than the floor touches it"),
        ],
        default="START",
    )
    handover_frame: IntProperty(name="Hand-over Frame", default=1)
    motors: FloatProperty(
        name="Motors",
        description="How strongly joint motors follow the action (0: a limp ragdoll)",
        min=0.0,
        max=1.0,
        default=0.0,
    )
    crowd: bpy.props.PointerProperty(
        name="Crowd",
        type=bpy.types.Collection,
        description="Bake every armature of this collection as one crowd instead of the selection",
    )
    report: StringProperty(name="Report", description="The last bake's report (JSON)")
    status: StringProperty(name="Status", description="The last operator's message")


class RagdollObjectProps(bpy.types.PropertyGroup):
    kind: EnumProperty(
        name="Kind",
        items=[
            ("NONE", "None", ""),
            ("CHARGE", "Charge", "An explosive charge"),
            ("PROJECTILE", "Projectile", "A projectile flying along the empty's Z axis"),
        ],
        default="NONE",
    )
    tnt_kg: FloatProperty(name="TNT (kg)", min=0.0001, max=100000.0, default=5.0)
    air: BoolProperty(
        name="In the Air",
        description="Goes off where the empty is; otherwise it lies on the floor",
        default=False,
    )
    frame: IntProperty(name="Frame", description="Detonation or impact frame", default=1)
    mass_kg: FloatProperty(name="Mass (kg)", min=0.0001, max=1000.0, default=0.008)
    speed_mps: FloatProperty(name="Speed (m/s)", min=0.0, max=10000.0, default=360.0)


CLASSES = (RagdollSceneProps, RagdollObjectProps)


def register():
    for c in CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Scene.ragdoll = bpy.props.PointerProperty(type=RagdollSceneProps)
    bpy.types.Object.ragdoll = bpy.props.PointerProperty(type=RagdollObjectProps)


def unregister():
    del bpy.types.Object.ragdoll
    del bpy.types.Scene.ragdoll
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
