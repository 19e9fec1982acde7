"""Writes the Honeybee sample model with honeybee's own Python library.

Two rooms side by side, apertures on the south and east façades, an overhang over the south
windows, a context building across the street to the south, honeybee's default modifiers,
one sensor grid and one view per room. Writes, next to this script:

- model.hbjson: the model in metres;
- model_mm.hbjson: the same model converted to millimetres by honeybee;
- rad/: the Radiance folder honeybee-radiance writes for it (model_to_rad_folder), whose
  scene .rad/.mat files and grid .pts files the Radiance bench runs on
  (tests/bench/radiance/honeybee.py), and rad/sensors.pts, every grid in model order.

Regenerate with (network needed once for pip):

    python3 -m venv target/hb-venv && target/hb-venv/bin/pip install honeybee-radiance
    target/hb-venv/bin/python scenes/honeybee/make_model.py

Made with honeybee-core 1.64.79, honeybee-radiance 1.66.299.
"""

import json
import os
import pathlib
import shutil
import sys

# honeybee fills some lists from sets, whose order follows Python's string hashing: a fixed
# hash seed makes the files the same on every run.
if os.environ.get("PYTHONHASHSEED") != "0":
    os.execve(sys.executable, [sys.executable] + sys.argv,
              dict(os.environ, PYTHONHASHSEED="0"))

from honeybee.model import Model
from honeybee.room import Room
from honeybee.shade import Shade
from honeybee_radiance.view import View
from honeybee_radiance.writer import model_to_rad_folder
from ladybug_geometry.geometry3d import Face3D, Point3D, Vector3D

HERE = pathlib.Path(__file__).resolve().parent


def facing(room, x, y):
    """The room's wall whose outward normal points along (x, y)."""
    for face in room.faces:
        n = face.normal
        if abs(n.x - x) < 1e-6 and abs(n.y - y) < 1e-6 and abs(n.z) < 1e-6:
            return face
    raise ValueError(f"{room.identifier}: no wall facing ({x}, {y})")


def main():
    west = Room.from_box("Room_West", 6, 5, 3, origin=Point3D(0, 0, 0))
    east = Room.from_box("Room_East", 6, 5, 3, origin=Point3D(6, 0, 0))
    Room.solve_adjacency([west, east], tolerance=0.001)

    # South windows (y = 0 faces south, -y), 40 % of the wall, 0.8 m sill, with a 1 m
    # overhang; one east window on the east room.
    for room in (west, east):
        south = facing(room, 0, -1)
        south.apertures_by_ratio_rectangle(0.4, 1.5, 0.8, 3.0, tolerance=0.001)
        for ap in south.apertures:
            ap.overhang(1.0, indoor=False, tolerance=0.001)
    facing(east, 1, 0).apertures_by_ratio(0.3)

    # Context: a block 12 m south of the façade, 24 m long, 12 m high, as shades.
    cx0, cx1, cy0, cy1, h = -6.0, 18.0, -20.0, -12.0, 12.0
    pts = [Point3D(cx0, cy0, 0), Point3D(cx1, cy0, 0), Point3D(cx1, cy1, 0),
           Point3D(cx0, cy1, 0)]
    context = []
    for i in range(4):
        a, b = pts[i], pts[(i + 1) % 4]
        wall = Face3D([a, b, Point3D(b.x, b.y, h), Point3D(a.x, a.y, h)])
        context.append(Shade(f"Context_Wall_{i}", wall, is_detached=True))
    roof = Face3D([Point3D(p.x, p.y, h) for p in pts])
    context.append(Shade("Context_Roof", roof, is_detached=True))

    model = Model("Two_Rooms", rooms=[west, east], orphaned_shades=context,
                  units="Meters", tolerance=0.001, angle_tolerance=1.0)
    grids = []
    for room in (west, east):
        g = room.properties.radiance.generate_sensor_grid(0.5, offset=0.8,
                                                          wall_offset=0.5)
        g.identifier = f"{room.identifier}_Grid"
        grids.append(g)
    model.properties.radiance.sensor_grids = grids
    views = [
        View("West_Inside", position=(0.5, 4.5, 1.5), direction=(1, -1, 0),
             up_vector=(0, 0, 1), h_size=60, v_size=45),
        View("East_Inside", position=(11.5, 4.5, 1.5), direction=(-1, -1, 0),
             up_vector=(0, 0, 1), h_size=60, v_size=45),
    ]
    model.properties.radiance.views = views

    # Keys sorted, so that the files compare line by line across honeybee versions.
    (HERE / "model.hbjson").write_text(json.dumps(model.to_dict(), sort_keys=True, indent=1))
    mm = model.duplicate()
    mm.convert_to_units("Millimeters")
    (HERE / "model_mm.hbjson").write_text(json.dumps(mm.to_dict(), sort_keys=True, indent=1))

    rad = HERE / "rad"
    if rad.exists():
        shutil.rmtree(rad)
    model_to_rad_folder(model, folder=str(rad))
    # All grids in model order in one .pts, for scene_rad.toml and the Radiance bench.
    grid_dir = rad / "model" / "grid"
    (rad / "sensors.pts").write_text("".join(
        (grid_dir / f"{g.identifier}.pts").read_text() for g in grids))


if __name__ == "__main__":
    main()
