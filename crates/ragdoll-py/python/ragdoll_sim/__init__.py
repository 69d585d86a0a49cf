"""Turns any character into a physically simulated ragdoll and bakes what happens to it.

The engine is the Rust library ``ragdoll``; this package calls it directly::

    import ragdoll_sim as rd

    hero = rd.load("hero.glb")                 # glTF, GLB, VRM, BVH or OBJ
    world = rd.World(backend="rigid")
    h = world.add(hero, at=(0, 0, 0))
    world.add_blast(tnt_kg=5.0, at=(2.0, 0.0, 1.0), time_s=0.1)
    result = world.run(3.0, fps=30)
    local = result.transforms(h)               # (frames, joints, 10) numpy array
    result.save("hero_blast.glb")

Units are metres, kilograms and seconds, Y up; transforms are rows of ten numbers:
translation, rotation quaternion x y z w, scale. Errors are subclasses of
``RagdollError`` whose attributes (``file``, ``line``, ``place``, ``key``, ``joint``,
``message``) say where the problem is.
"""

from ragdoll_sim._native import (
    Body,
    BoundError,
    Cancelled,
    Character,
    FileAccessError,
    FileFormatError,
    InternalError,
    Joint,
    RagdollError,
    Result,
    Roles,
    RoleError,
    Simulation,
    SkeletonError,
    Spec,
    SpecError,
    World,
    __version__,
    build_ragdoll,
    humanoid,
    load,
)

__all__ = [
    "Body",
    "BoundError",
    "Cancelled",
    "Character",
    "FileAccessError",
    "FileFormatError",
    "InternalError",
    "Joint",
    "RagdollError",
    "Result",
    "Roles",
    "RoleError",
    "Simulation",
    "SkeletonError",
    "Spec",
    "SpecError",
    "World",
    "__version__",
    "build_ragdoll",
    "humanoid",
    "load",
]
