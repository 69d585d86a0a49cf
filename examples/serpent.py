#!/usr/bin/env python3
"""Writes examples/serpent.obj: a small serpent of our own making (a tube along a curved
centre line, thick in the middle, tapering to the tail, its neck raised to a rounded head),
so the rigging example runs on a clone without ../shared/data.

    python3 examples/serpent.py > examples/serpent.obj

Metres, Y up, lying on the floor along X with the head at +X. Pure arithmetic: the same
file comes out every time.
"""
import math

RINGS = 40  # cross-sections from the tail tip to the snout
SIDES = 12  # vertices around each cross-section


def smoothstep(a, b, x):
    s = min(max((x - a) / (b - a), 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


def radius(t):
    """Thin tail, thick body, a narrower neck, a rounded head."""
    body = 0.065 * math.sin(math.pi * min(t / 0.9, 1.0)) ** 0.6
    head = 0.045 * math.exp(-(((t - 0.93) / 0.045) ** 2))
    return 0.008 + body + head


def centre(t):
    """Along X, swaying in Z, resting on the floor, the neck rising over the last third."""
    x = -0.7 + 1.4 * t
    z = 0.12 * math.sin(2.0 * math.pi * 1.1 * t) * (1.0 - smoothstep(0.7, 1.0, t))
    y = radius(t) + 0.32 * smoothstep(0.66, 0.95, t)
    return (x, y, z)


def sub(a, b):
    return tuple(p - q for p, q in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def unit(a):
    n = math.sqrt(sum(p * p for p in a))
    return tuple(p / n for p in a)


def main():
    ts = [i / (RINGS - 1) for i in range(RINGS)]
    verts = []
    for i, t in enumerate(ts):
        c = centre(t)
        ahead = centre(min(t + 1e-3, 1.0))
        behind = centre(max(t - 1e-3, 0.0))
        tangent = unit(sub(ahead, behind))
        side = unit(cross(tangent, (0.0, 1.0, 0.0)))
        up = cross(side, tangent)
        # The ends close to a point: the last ring of each end is shrunk to its centre.
        r = radius(t) if 0 < i < RINGS - 1 else 0.0
        for k in range(SIDES):
            a = 2.0 * math.pi * k / SIDES
            verts.append(
                tuple(c[j] + r * (math.cos(a) * side[j] + math.sin(a) * up[j]) for j in range(3))
            )
    print("# A serpent made for ragdoll's examples by examples/serpent.py (our own mesh,")
    print("# licensed like the repository). Metres, Y up, head at +X.")
    print("o serpent")
    # Closed ends: the first and last rings are one point each.
    for v in verts[:1] + verts[SIDES:-SIDES] + verts[-SIDES:][:1]:
        print("v %.4f %.4f %.4f" % v)
    # Vertex numbers (1-based) after dropping the repeated end points.
    def ring(i, k):
        if i == 0:
            return 1
        if i == RINGS - 1:
            return 2 + (RINGS - 2) * SIDES
        return 2 + (i - 1) * SIDES + k % SIDES

    for i in range(RINGS - 1):
        for k in range(SIDES):
            a, b = ring(i, k), ring(i, k + 1)
            c, d = ring(i + 1, k), ring(i + 1, k + 1)
            for f in ((a, c, b), (b, c, d)):
                if len(set(f)) == 3:
                    print("f %d %d %d" % f)


if __name__ == "__main__":
    main()
