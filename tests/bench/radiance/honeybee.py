"""Validation of daystep's model import against Radiance on the Honeybee sample model.

The model (scenes/honeybee, written by honeybee's own Python library with make_model.py)
is run three ways through daystep at --quality default, cold:
  - from its HBJSON (scene.toml), the way a Ladybug Tools user gives it;
  - from the same model converted to millimetres by honeybee (scene_mm.toml);
  - from the Radiance files honeybee-radiance wrote for it (scene_rad.toml).
The reference is Radiance itself, run on those same honeybee-written .mat/.rad files and
grid .pts (not on anything daystep wrote): rtrace -I, path traced without an irradiance
cache (validate.py's REFERENCE settings), under the two bench skies (validate.py's
instant_specs: a Perez sky with sun and a CIE overcast sky).

Run through tests/bench/radiance/run-honeybee.sh (makes the Radiance venv, builds daystep),
or by hand:

    target/radiance-venv/bin/python tests/bench/radiance/honeybee.py [--quick] [--only perez]

Prints one markdown table per sky (RMS, within 5 % + 10 lx, lux_err coverage, time) and
the differences between the three ways of giving the model (max |difference| over the
sensors, absolute and relative to daystep's stated lux_err). Not part of `cargo test`.
"""

import argparse
import hashlib
import json
import math
import os
import sys
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import validate as v  # noqa: E402

REPO = v.REPO
MODEL = REPO / "scenes/honeybee"
RAD_FILES = ["scene/envelope.mat", "scene/envelope.rad", "scene/shades.mat",
             "scene/shades.rad", "aperture/aperture.mat", "aperture/aperture.rad"]


def within(vals, ref):
    """Share of sensors above LUX_MIN with |daystep − reference| ≤ 5 % + 10 lx, in %."""
    ks = [k for k, r in enumerate(ref) if r > v.LUX_MIN]
    ok = sum(1 for k in ks if abs(vals[k] - ref[k]) <= 0.05 * ref[k] + 10.0)
    return 100.0 * ok / len(ks)


def cached_rtrace(d, octree, pts_text, opts, env, nproc):
    """validate.rtrace, kept in d keyed by the octree's, sensors' and settings' content, so
    that re-running the bench after a daystep change does not redo the reference."""
    key = hashlib.sha256(octree.read_bytes() + pts_text.encode() + opts.encode()).hexdigest()
    f = d / f"rtrace-{key[:16]}.json"
    if f.exists():
        c = json.loads(f.read_text())
        return c["vals"], c["secs"], c["cmd"]
    vals, secs, cmd = v.rtrace(octree, pts_text, opts, env, nproc)
    f.write_text(json.dumps({"vals": vals, "secs": secs, "cmd": cmd}))
    return vals, secs, cmd


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--daystep", default=str(REPO / "target/release/daystep"))
    ap.add_argument("--work", default=str(REPO / "target/radiance-bench/honeybee"))
    ap.add_argument("--nproc", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--quick", action="store_true", help="small reference (checks the bench)")
    ap.add_argument("--only", choices=["perez", "overcast"])
    ap.add_argument("--ways", default="hbjson,mm,rad",
                    help="which of daystep's readings to run (comma-separated: hbjson, mm, rad)")
    ap.add_argument("--reference-only", action="store_true",
                    help="only compute (and keep) Radiance's references")
    a = ap.parse_args()
    env, bindir, _ = v.radiance_env()
    exe = Path(a.daystep)
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    ref_opts = v.QUICK_REFERENCE if a.quick else v.REFERENCE
    for line in v.machine_lines(env):
        print(line)
    print(f"daystep: {v.run([str(exe), '--version'], env).strip()}; Radiance: {bindir}")
    print()

    sc = tomllib.loads((MODEL / "scene.toml").read_text())
    site, rho_g = sc["site"], float(sc["ground_reflectance"])
    rad = MODEL / "rad/model"
    pts_text = (MODEL / "rad/sensors.pts").read_text()
    n = len(pts_text.splitlines())
    print(f"model: scenes/honeybee/model.hbjson, {n} sensors in "
          + ", ".join(g["identifier"] for g in json.loads(
              (rad / "grid/_model_grids_info.json").read_text())))
    print("Radiance scene: honeybee-radiance's " + ", ".join(RAD_FILES))
    print()
    ways = [(label, scene) for key, label, scene in
            [("hbjson", "HBJSON", MODEL / "scene.toml"),
             ("mm", "HBJSON in mm", MODEL / "scene_mm.toml"),
             ("rad", "honeybee's .rad", MODEL / "scene_rad.toml")]
            if key in a.ways.split(",")]
    for key, title, skycmd, dsargs in v.instant_specs(
            float(site["latitude"]), float(site["longitude"]), float(site["utc_offset_h"]),
            rho_g):
        if a.only and a.only != key:
            continue
        d = work / key
        octree = v.sky_octree(d, skycmd, [rad / f for f in RAD_FILES], env)
        half_opts = v.QUICK_REFERENCE_HALF if a.quick else v.REFERENCE_HALF
        ref, t_ref, cmd_ref = cached_rtrace(d, octree, pts_text, ref_opts, env, a.nproc)
        half, _, _ = cached_rtrace(d, octree, pts_text, half_opts, env, a.nproc)
        if a.reference_only:
            continue
        pair = [(h - r) / r for h, r in zip(half, ref) if r > v.LUX_MIN]
        ref_noise = math.sqrt(sum(x * x for x in pair) / len(pair) / 3.0)
        print(f"## {title}")
        print()
        print(f"sky: `{' '.join(skycmd)}`; reference: `{cmd_ref}` ({t_ref:.0f} s, noise "
              f"≈{100 * ref_noise:.2f} %)")
        print()
        print("| daystep --quality default, cold, from | wall s | mean \\|rel. diff.\\| | bias "
              "| RMS | max | median lux_err/lux | within lux_err | within 5 % + 10 lx |")
        print("|---|---|---|---|---|---|---|---|---|")
        got = {}
        for label, scene in ways:
            rows, secs, _, _ = v.daystep_instant(exe, scene, dsargs, d / f"daystep-{label[:6]}"
                                                 .replace(" ", "_").replace("'", ""),
                                                 "default", env, threads=a.nproc)
            if len(rows) != n:
                sys.exit(f"{label}: daystep gave {len(rows)} sensors, the .pts has {n}")
            vals, errs = [r["lux"] for r in rows], [r["lux_err"] for r in rows]
            got[label] = (vals, errs)
            c = v.compare(vals, ref, errs, ref_noise)
            print(v.fmt_row(label, secs, c) + f" {within(vals, ref):.1f} % |")
        print()
        base, errs = got.get("HBJSON", (None, None))
        for label in ("HBJSON in mm", "honeybee's .rad"):
            if base is None or label not in got:
                continue
            other = got[label][0]
            diff = [abs(o - b) for o, b in zip(other, base)]
            worst = max(diff)
            ratio = max(dd / (e if e > 0 else 1e-9) for dd, e in zip(diff, errs))
            print(f"- {label} against HBJSON: max |difference| {worst:.3g} lx, at most "
                  f"{ratio:.3g} × lux_err")
        print()
    print("load average at the end (1, 5, 15 min): "
          + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
