#!/usr/bin/env python3
"""Writes the courtyard scene of the Radiance bench: courtyard.obj, courtyard.mtl,
courtyard.pts (scene.toml and README.md are written by hand).

    python3 tests/bench/radiance/courtyard/make_scene.py

Standard library only; the output is deterministic, so running it again changes nothing.

Metres, z up, x east, y north. Four free-standing walls, 6 m high and without thickness
(one surface each, as designers export them: quads of two triangles), enclose a 16 × 12 m
courtyard; a 60 × 60 m ground mesh lies under them. The triangles' winding (and the `vn`
written with them) makes each wall's normal point one way only:

| wall  | plane  | normal | courtyard side | outer side |
|-------|--------|--------|----------------|------------|
| south | y = 0  | −y     | back           | front      |
| north | y = 12 | +y     | back           | front      |
| west  | x = 0  | −x     | back           | front      |
| east  | x = 16 | −x     | front          | back       |

Under the bench's Perez sun (21 March 11:30, altitude 52°, 23.5° east of south) the
north wall's courtyard side (a back face), the west wall's courtyard side (back) and the
east wall's outer side (back) are in the sun, as is the south wall's outer side (front).

Sensors (group in a trailing `# group` comment, which daystep's .pts reader and the
bench's both skip or read; rtrace never sees it):
- ground-back / ground-front: horizontal, 5 cm above the ground, within 2 m of a wall
  whose face on the sensor's side is a back / front face (inside: the 1 m grid's cells
  nearest a wall; outside: a row 1 m from each outer side, every 2 m);
- ground-open: the rest of the courtyard's 1 m grid (more than 2 m from every wall);
- facade-in: vertical, 5 cm off each courtyard façade at 1.5 m and 4.5 m, every 2 m,
  facing the opposite wall;
- facade-out: vertical, 5 cm off each outer façade at 1.5 m, every 2 m, facing away.
"""

from pathlib import Path

HERE = Path(__file__).resolve().parent
LX, LY, H = 16.0, 12.0, 6.0  # courtyard (inside of the walls) and wall height, m
PANEL = 4.0  # wall panel width, m (a quad of two triangles each)
Z_SENSOR = 0.05  # ground sensors, m above the ground
OFF = 0.05  # façade sensors, m off the wall

# (name, fixed axis, fixed value, normal, length along the free horizontal axis)
WALLS = [
    ("south", "y", 0.0, (0, -1, 0), LX),
    ("north", "y", LY, (0, 1, 0), LX),
    ("west", "x", 0.0, (-1, 0, 0), LY),
    ("east", "x", LX, (-1, 0, 0), LY),
]


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


class Obj:
    def __init__(self):
        self.v, self.vn, self.faces = [], [], []  # faces: (material, [(vi, ni)…])

    def vert(self, p):
        if p not in self.v:
            self.v.append(p)
        return self.v.index(p) + 1

    def norm(self, n):
        if n not in self.vn:
            self.vn.append(n)
        return self.vn.index(n) + 1

    def quad(self, mat, corners, normal):
        """Two triangles over the four corners (in order round the quad), wound so that
        their geometric normal is `normal`."""
        a, b, c, d = corners
        if dot(cross(sub(b, a), sub(c, a)), normal) < 0:
            a, b, c, d = a, d, c, b
        n = self.norm(normal)
        ia, ib, ic, id_ = (self.vert(p) for p in (a, b, c, d))
        self.faces.append((mat, [(ia, n), (ib, n), (ic, n)]))
        self.faces.append((mat, [(ia, n), (ic, n), (id_, n)]))

    def text(self):
        out = ["# daystep Radiance bench: courtyard of free-standing single-surface walls",
               "# written by make_scene.py; metres, z up, x east, y north",
               "mtllib courtyard.mtl"]
        out += [f"v {x:g} {y:g} {z:g}" for x, y, z in self.v]
        out += [f"vn {x:g} {y:g} {z:g}" for x, y, z in self.vn]
        cur = None
        for mat, f in self.faces:
            if mat != cur:
                out.append(f"usemtl {mat}")
                cur = mat
            out.append("f " + " ".join(f"{v}//{n}" for v, n in f))
        return "\n".join(out) + "\n"


def build_obj():
    o = Obj()
    # Ground: 6 × 6 quads of 10 m, x −22 … 38, y −24 … 36 (courtyard in the middle).
    for i in range(6):
        for j in range(6):
            x0, y0 = -22.0 + 10 * i, -24.0 + 10 * j
            o.quad("ground", [(x0, y0, 0.0), (x0 + 10, y0, 0.0), (x0 + 10, y0 + 10, 0.0),
                              (x0, y0 + 10, 0.0)], (0, 0, 1))
    for name, axis, val, normal, length in WALLS:
        n_panels = int(length / PANEL)
        for k in range(n_panels):
            s0, s1 = k * PANEL, (k + 1) * PANEL
            if axis == "y":
                c = [(s0, val, 0.0), (s1, val, 0.0), (s1, val, H), (s0, val, H)]
            else:
                c = [(val, s0, 0.0), (val, s1, 0.0), (val, s1, H), (val, s0, H)]
            o.quad("wall", c, normal)
    return o


def face_side(wall, inside):
    """'back' or 'front': the face of `wall` on the courtyard side (inside) or outside."""
    _, axis, val, normal, _ = wall
    centre = (LX / 2, LY / 2)
    to_inside = (centre[0] - val) if axis == "x" else (centre[1] - val)
    n = normal[0] if axis == "x" else normal[1]
    normal_points_inside = n * to_inside > 0
    return "front" if normal_points_inside == inside else "back"


def build_pts():
    lines = []

    def add(p, d, group):
        lines.append(" ".join(f"{v:g}" for v in p) + " " + " ".join(f"{v:g}" for v in d)
                     + f" # {group}")

    # Courtyard ground, 1 m grid at cell centres.
    for j in range(int(LY)):
        for i in range(int(LX)):
            x, y = i + 0.5, j + 0.5
            dists = [(y, WALLS[0]), (LY - y, WALLS[1]), (x, WALLS[2]), (LX - x, WALLS[3])]
            d, wall = min(dists, key=lambda t: t[0])
            group = "ground-open" if d > 2.0 else f"ground-{face_side(wall, True)}"
            add((x, y, Z_SENSOR), (0, 0, 1), group)
    # Outside ground rows, 1 m from each outer side, every 2 m.
    for wall in WALLS:
        _, axis, val, normal, length = wall
        out_sign = -1.0 if val == 0.0 else 1.0
        for s in range(1, int(length), 2):
            p = (val + out_sign, s, Z_SENSOR) if axis == "x" else (s, val + out_sign, Z_SENSOR)
            add(p, (0, 0, 1), f"ground-{face_side(wall, False)}")
    # Façades: courtyard sides at 1.5 and 4.5 m facing the opposite wall; outer sides at
    # 1.5 m facing away.
    for wall in WALLS:
        _, axis, val, normal, length = wall
        in_sign = 1.0 if val == 0.0 else -1.0
        for z, sign, group in ((1.5, in_sign, "facade-in"), (4.5, in_sign, "facade-in"),
                               (1.5, -in_sign, "facade-out")):
            for s in range(1, int(length), 2):
                if axis == "x":
                    p, d = (val + sign * OFF, s, z), (sign, 0, 0)
                else:
                    p, d = (s, val + sign * OFF, z), (0, sign, 0)
                add(p, d, group)
    return "# daystep Radiance bench: courtyard sensors, x y z dx dy dz # group\n" + \
        "\n".join(lines) + "\n"


MTL = """# daystep Radiance bench: courtyard materials (Kd reflectance)

newmtl wall
Kd 0.5 0.5 0.5

newmtl ground
Kd 0.2 0.2 0.2
"""


def main():
    (HERE / "courtyard.obj").write_text(build_obj().text())
    (HERE / "courtyard.mtl").write_text(MTL)
    (HERE / "courtyard.pts").write_text(build_pts())


if __name__ == "__main__":
    main()
