#!/usr/bin/env python3
"""A daystep-layout .glb for the browser test, standard library only (struct, json).

    make_test_glb.py OUT.glb          write the test room
    make_test_glb.py --glb FILE.glb   check FILE against the layout, print a summary

The room is 6 m (east) x 8 m (north) x 3 m (up) with its window wall at north y = 0 (a
glazing band 0.9..2.4 m high, material alphaMode BLEND, alpha 0.3). COLOR_0 falls off
with the distance from the window, so the window side is brighter than the back; frame 1
is a darker, warmer afternoon, so the two frames' images differ. A 6 x 8 sensor grid at
0.8 m carries lux per frame.

glTF frame: (x, y, z) = (east, up, -north), so the window wall is the plane z = 0 and the
back wall z = -8. The summary line (JSON) names the camera the test uses: standing at the
room's centre at 1.5 m, looking east, the window side is the right of the image.
"""
import json
import math
import struct
import sys

RADIANCE_SCALE = 2.0  # W sr^-1 m^-2 per COLOR_0 unit
FRAMES = [
    # label, brightness at the window, colour tint (linear RGB), sensor lux at the window
    ("2021-03-21T12:00", 1.0, (1.0, 1.0, 1.0), 2400.0),
    ("2021-03-21T16:00", 0.45, (1.0, 0.8, 0.55), 900.0),
]
MATERIALS = [  # name, Kd, glazing
    ("walls", (0.6, 0.6, 0.6), False),
    ("floor", (0.3, 0.3, 0.3), False),
    ("ceiling", (0.8, 0.8, 0.8), False),
    ("glazing", (0.9, 0.9, 0.9), True),
]
W, D, H = 6.0, 8.0, 3.0
SILL, HEAD = 0.9, 2.4


def to_gltf(p):
    """daystep's (east, north, up) to glTF's (east, up, -north)."""
    return (p[0], p[2], -p[1])


def falloff(north):
    """Relative daylight at a distance `north` (m) from the window."""
    return 0.12 + 0.88 * math.exp(-north / 2.5)


def grid(prim, origin, u, v, nu, nv, normal):
    """A quad origin + s*u + t*v (s, t in [0, 1]) as nu x nv cells appended to prim."""
    base = len(prim["pos"])
    for j in range(nv + 1):
        for i in range(nu + 1):
            s, t = i / nu, j / nv
            prim["pos"].append(tuple(origin[k] + s * u[k] + t * v[k] for k in range(3)))
            prim["nrm"].append(normal)
    for j in range(nv):
        for i in range(nu):
            a = base + j * (nu + 1) + i
            b, c, d = a + 1, a + nu + 1, a + nu + 2
            prim["idx"] += [a, b, d, a, d, c]


def room():
    prims = {name: {"pos": [], "nrm": [], "idx": []} for name, _, _ in MATERIALS}
    w = prims["walls"]
    grid(prims["floor"], (0, 0, 0), (W, 0, 0), (0, D, 0), 12, 16, (0, 0, 1))
    grid(prims["ceiling"], (0, 0, H), (W, 0, 0), (0, D, 0), 12, 16, (0, 0, -1))
    grid(w, (0, D, 0), (W, 0, 0), (0, 0, H), 12, 6, (0, -1, 0))  # back wall
    grid(w, (0, 0, 0), (0, D, 0), (0, 0, H), 16, 6, (1, 0, 0))  # west wall
    grid(w, (W, 0, 0), (0, D, 0), (0, 0, H), 16, 6, (-1, 0, 0))  # east wall
    grid(w, (0, 0, 0), (W, 0, 0), (0, 0, SILL), 12, 2, (0, 1, 0))  # below the window
    grid(w, (0, 0, HEAD), (W, 0, 0), (0, 0, H - HEAD), 12, 1, (0, 1, 0))  # above it
    grid(prims["glazing"], (0, 0, SILL), (W, 0, 0), (0, 0, HEAD - SILL), 6, 2, (0, 1, 0))
    return prims


class Bin:
    def __init__(self):
        self.data = bytearray()
        self.views, self.accessors = [], []

    def add(self, fmt, values, comp, kind, count, minmax=False, target=None):
        while len(self.data) % 4:
            self.data.append(0)
        raw = struct.pack("<" + fmt * len(values), *values)
        view = {"buffer": 0, "byteOffset": len(self.data), "byteLength": len(raw)}
        if target:
            view["target"] = target
        self.data += raw
        self.views.append(view)
        acc = {"bufferView": len(self.views) - 1, "componentType": comp, "count": count, "type": kind}
        if minmax:
            n = len(values) // count
            acc["min"] = [min(values[k::n]) for k in range(n)]
            acc["max"] = [max(values[k::n]) for k in range(n)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def vec3(self, rows, minmax=False):
        return self.add("f", [c for r in rows for c in r], 5126, "VEC3", len(rows), minmax, 34962)

    def scalar(self, values):
        return self.add("f", list(values), 5126, "SCALAR", len(values), False, 34962)


def write(path):
    b = Bin()
    prims = room()
    meshes, frames = [], [{"label": f[0], "primitives": []} for f in FRAMES]
    for mi, (name, kd, glazing) in enumerate(MATERIALS):
        p = prims[name]
        pos = [to_gltf(q) for q in p["pos"]]
        nrm = [to_gltf(n) for n in p["nrm"]]
        prim = {
            "mode": 4,
            "material": mi,
            "indices": b.add("I", p["idx"], 5125, "SCALAR", len(p["idx"]), False, 34963),
            "attributes": {"POSITION": b.vec3(pos, minmax=True), "NORMAL": b.vec3(nrm)},
        }
        for fi, (_, level, tint, _) in enumerate(FRAMES):
            col, lum, ill = [], [], []
            for q in p["pos"]:
                e = level * falloff(q[1])
                rgb = tuple(min(1.0, 0.85 * e * kd[k] * tint[k] / 0.6) for k in range(3))
                col.append(rgb)
                radiance = [c * RADIANCE_SCALE for c in rgb]
                l = 179.0 * (0.265 * radiance[0] + 0.670 * radiance[1] + 0.065 * radiance[2])
                lum.append(l)
                ill.append(math.pi * l / max(kd[1], 0.05))
            acc = {"COLOR_0": b.vec3(col), "_ILLUMINANCE": b.scalar(ill), "_LUMINANCE": b.scalar(lum)}
            frames[fi]["primitives"].append(acc)
            if fi == 0:
                prim["attributes"].update(acc)
        meshes.append(prim)
    sensors_xyz = [(x + 0.5, y + 0.5, 0.8) for y in range(8) for x in range(6)]
    sensors = {
        "positions": b.vec3([to_gltf(s) for s in sensors_xyz]),
        "lux": [b.scalar([f[3] * falloff(s[1]) for s in sensors_xyz]) for f in FRAMES],
    }
    materials = []
    for name, kd, glazing in MATERIALS:
        m = {"name": name, "doubleSided": True,
             "pbrMetallicRoughness": {"baseColorFactor": [*kd, 0.3 if glazing else 1.0],
                                      "metallicFactor": 0.0, "roughnessFactor": 1.0}}
        if glazing:
            m["alphaMode"] = "BLEND"
        materials.append(m)
    doc = {
        "asset": {"version": "2.0", "generator": "daystep tests/browser/make_test_glb.py",
                  "extras": {"daystep": {"version": 1, "radiance_scale": RADIANCE_SCALE,
                                         "frames": frames, "sensors": sensors}}},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"name": "solution", "primitives": meshes}],
        "materials": materials,
        "buffers": [{"byteLength": len(b.data)}],
        "bufferViews": b.views, "accessors": b.accessors,
    }
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    bin_ = bytes(b.data) + b"\0" * (-len(b.data) % 4)
    doc["buffers"][0]["byteLength"] = len(b.data)
    total = 12 + 8 + len(js) + 8 + len(bin_)
    with open(path, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, total))
        f.write(struct.pack("<II", len(js), 0x4E4F534A) + js)
        f.write(struct.pack("<II", len(bin_), 0x004E4942) + bin_)


def check(path):
    """Reads FILE's GLB container and daystep extras; prints a one-line JSON summary."""
    raw = open(path, "rb").read()
    magic, version, length = struct.unpack_from("<III", raw, 0)
    if magic != 0x46546C67 or version != 2:
        sys.exit(f"{path}: not a glTF 2.0 binary")
    jlen, jtype = struct.unpack_from("<II", raw, 12)
    if jtype != 0x4E4F534A:
        sys.exit(f"{path}: first chunk is not JSON")
    doc = json.loads(raw[20:20 + jlen])
    ext = doc.get("asset", {}).get("extras", {}).get("daystep")
    if not ext or not ext.get("frames"):
        sys.exit(f"{path}: no asset.extras.daystep.frames")
    prims = doc["meshes"][doc["nodes"][doc["scenes"][0]["nodes"][0]]["mesh"]]["primitives"]
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    for p in prims:
        a = doc["accessors"][p["attributes"]["POSITION"]]
        lo = [min(x, y) for x, y in zip(lo, a["min"])]
        hi = [max(x, y) for x, y in zip(hi, a["max"])]
        for key in ("COLOR_0", "_ILLUMINANCE", "_LUMINANCE", "NORMAL"):
            if key not in p["attributes"]:
                sys.exit(f"{path}: a primitive has no {key}")
    for f in ext["frames"]:
        if len(f["primitives"]) != len(prims):
            sys.exit(f"{path}: frame {f.get('label')} has {len(f['primitives'])} primitives, mesh {len(prims)}")
    return {"frames": len(ext["frames"]), "primitives": len(prims), "min": lo, "max": hi,
            "sensors": ext.get("sensors") is not None}


def main():
    args = sys.argv[1:]
    if len(args) == 2 and args[0] == "--glb":
        path = args[1]
    elif len(args) == 1 and not args[0].startswith("-"):
        path = args[0]
        write(path)
    else:
        sys.exit(__doc__)
    print(json.dumps(check(path)))


if __name__ == "__main__":
    main()
