#!/usr/bin/env python3
"""daystep render against Radiance on the sample office (issue 15; not part of `cargo test`).

Run it through `tests/bench/render/run.sh`. For a sunny and an overcast instant (the same
skies as tests/bench/radiance/validate.py) and one camera looking at the window wall:

1. Radiance: `vwrays` gives every pixel's ray; `rtrace -oM`/`-on` names what each pixel
   sees (regions: the window wall, the back wall, the floor, the floor's sun patch where
   the direct-only `-ab 0` value is above half the floor's largest); a converged
   reference per pixel with `rtrace -aa 0 -as 0` (brute force, high -ab), the mean
   luminance of each region; rpict at `-ab 5` and at Honeybee's image recipe settings,
   timed.
2. daystep: `daystep render` of the same view and size (`--hdr`, read back with
   `pvalue`), cold (no cache) and warm (cache filled), timed; the same region means.
3. A markdown table: region means, differences, and the mean stated error of daystep's
   pixels in the region.
"""

import argparse
import math
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "radiance"))
import validate as v  # noqa: E402  (the office's conversion to Radiance, the skies)

REPO = v.REPO
VIEW = "-vtv -vp 3 7.5 1.5 -vd 0 -1 -0.1 -vu 0 0 1 -vh 70 -vv 50"
# From beside the window towards the back wall.
VIEW_BACK = "-vtv -vp 3 0.6 1.5 -vd 0 1 -0.15 -vu 0 0 1 -vh 80 -vv 60"
# Brute force: no irradiance cache, deep bounces (validate.py's reference, fewer
# divisions: region means average thousands of pixels).
REFERENCE = "-ab 10 -aa 0 -as 0 -ad 2048 -lr 0 -lw 1e-5 -dj 0 -dt 0 -dc 1 -st 0"
# Honeybee's rpict parameters at its default quality 0 (RpictParameters(0)), and the same
# with five ambient bounces.
RPICT_HONEYBEE = "-aa 0.25 -ab 2 -ad 512 -dc 0.25 -st 0.85 -lw 0.05 -as 128 -ar 16 -lr 4 -dt 0.5 -dr 0 -ds 0.5 -dp 64"
RPICT_AB5 = RPICT_HONEYBEE.replace("-ab 2", "-ab 5").replace("-lw 0.05", "-lw 0.002")


def pixel_rays(w, h, env, cwd, view):
    out = v.run(["vwrays", "-fa", "-pa", "0", "-x", str(w), "-y", str(h)] + view.split(), env, cwd=cwd)
    rays = [l for l in out.splitlines() if l.strip()]
    if len(rays) != w * h:
        sys.exit(f"vwrays gave {len(rays)} rays for {w}x{h}")
    return "\n".join(rays) + "\n"


def rtrace_values(octree, rays, opts, env, nproc, cwd):
    cmd = ["rtrace", "-fa", "-h", "-ov", "-n", str(nproc)] + v.two_sided(opts).split() + [str(octree)]
    t0 = time.perf_counter()
    out = v.run(cmd, env, stdin=rays, cwd=cwd)
    return [v.lux_of_rgb(l) for l in out.splitlines() if l.strip()], time.perf_counter() - t0


def classify(octree, rays, env, cwd):
    """Per pixel: material name and hit point (Radiance's own view of the scene)."""
    cmd = ["rtrace", "-fa", "-h", "-oMp", "-ab", "0"] + [str(octree)]
    out = v.run(cmd, env, stdin=rays, cwd=cwd)
    px = []
    for l in out.splitlines():
        f = l.split()
        if not f:
            continue
        # -oMp: material, then x y z; a ray that leaves the scene reports no material.
        if len(f) >= 4:
            px.append((f[0], tuple(map(float, f[1:4]))))
        else:
            px.append(("sky", (0.0, 0.0, 0.0)))
    return px


def regions(px, direct, w, h):
    """Pixels by what Radiance's centre ray meets, each region eroded by one pixel: a pixel
    whose 8 neighbours are not all of its region is left out, because daystep's pixel is
    the mean over its area (antialiased) and Radiance's reference is its centre ray, which
    differ wherever a pixel straddles an edge of high contrast (window frame, sun patch)."""
    floor = [i for i, (m, p) in enumerate(px) if m == "m_floor"]
    top = max((direct[i] for i in floor), default=0.0)
    sun = {i for i in floor if top > 0 and direct[i] > 0.5 * top}
    label = []
    for i, (m, p) in enumerate(px):
        if i in sun:
            label.append("floor sun patch")
        elif m == "m_floor":
            label.append("floor (shade)")
        elif m == "m_wall" and abs(p[1]) < 1e-3:
            label.append("window wall")
        elif m == "m_wall" and p[1] > 7.999:
            label.append("back wall")
        elif m == "m_wall":
            label.append("side walls and reveals")
        elif m == "m_ceiling":
            label.append("ceiling")
        else:
            label.append(m)
    out = {}
    for i, lab in enumerate(label):
        x, y = i % w, i // w
        inner = all(0 <= x + dx < w and 0 <= y + dy < h and label[(y + dy) * w + x + dx] == lab
                    for dx in (-1, 0, 1) for dy in (-1, 0, 1))
        if inner:
            out.setdefault(lab, []).append(i)
    return out


def read_hdr_values(path, env):
    out = v.run(["pvalue", "-h", "-H", "-o", "-d", str(path)], env)
    vals = [179.0 * (0.265 * float(a) + 0.670 * float(b) + 0.065 * float(c))
            for a, b, c in (l.split() for l in out.splitlines() if l.strip())]
    return vals


SPEED_VIEWS = {
    "office": [
        ("perspective 800×600", VIEW, 800, 600),
        ("fisheye 1000×1000", "-vta -vp 3 4 1.2 -vd 0 -1 0 -vu 0 0 1 -vh 180 -vv 180", 1000, 1000),
    ],
    "building-10k": [
        ("perspective 800×600", "-vtv -vp 5 15 1.5 -vd 0 -1 -0.1 -vu 0 0 1 -vh 70 -vv 50", 800, 600),
        ("fisheye 1000×1000", "-vta -vp 5 10 1.2 -vd 0 -1 0 -vu 0 0 1 -vh 180 -vv 180", 1000, 1000),
    ],
}
PEREZ_DAYSTEP = ["--time", "2024-03-21T11:30", "--sky", "perez", "--dni", "978", "--dhi", "86",
                 "--dew-point", "10.974"]


def timed(cmd, env, stdout=None):
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, stdout=stdout, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def speed(a, env):
    """Seconds per frame, cold and warm, and a warm sequence's frames per second, against
    rpict (single process) on the same views."""
    import json
    work = REPO / "target/render-bench/speed"
    work.mkdir(parents=True, exist_ok=True)
    scenes = {"office": REPO / "scenes/office/scene.toml",
              "building-10k": REPO / "target/bench-annual/scenes/building-10k/scene.toml"}
    print("| scene | view | daystep cold s | daystep warm s | warm sequence frames/s | "
          "rpict Honeybee s | rpict -ab 5 s |")
    print("|---|---|---|---|---|---|---|")
    for name, scene in scenes.items():
        if not scene.exists():
            print(f"| {name} | (missing: run `cargo bench --bench annual` once to write it) |")
            continue
        sc = tomllib.loads(scene.read_text())
        site = sc["site"]
        lat, lon, tz = float(site["latitude"]), float(site["longitude"]), float(site["utc_offset_h"])
        tris, mats = v.read_obj(scene.parent / sc["geometry"], sc.get("up", "z"),
                                float(sc.get("north_deg", 0.0)))
        d = work / name
        d.mkdir(exist_ok=True)
        v.write_radiance_scene(tris, mats, d / "scene.rad")
        sky = v.run(["gendaylit", "3", "21", "11.5", "-y", "2024", "-a", f"{lat}", "-o", f"{-lon}",
                     "-m", f"{-15.0 * tz:g}", "-W", "978", "86", "-g",
                     f"{sc.get('ground_reflectance', 0.2)}"], env)
        (d / "sky.rad").write_text(sky + v.glow_lines())
        octree = d / "scene.oct"
        octree.write_bytes(subprocess.run(["oconv", "-f", "sky.rad", "scene.rad"], env=env, cwd=d,
                                          capture_output=True, check=True).stdout)
        for label, view, w, h in SPEED_VIEWS[name]:
            cache = d / "cache"
            if cache.exists():
                shutil.rmtree(cache)
            base = [a.daystep, "render", str(scene), "--view", view, "-x", str(w), "-y", str(h),
                    "--cache", str(cache), "--threads", str(a.nproc)]
            runs = {}
            for run in ("cold", "warm"):
                out = d / f"out-{run}"
                if out.exists():
                    shutil.rmtree(out)
                runs[run] = timed(base + PEREZ_DAYSTEP + ["--out", str(out)], env)
            # The day once to fill the cache with its directions, then again, warm.
            for k in ("seq-fill", "seq"):
                seq = d / f"out-{k}"
                if seq.exists():
                    shutil.rmtree(seq)
                t = timed(base + ["--weather", str(REPO / "scenes/office/weather.epw"), "--start",
                                  "2021-03-21", "--end", "2021-03-21", "--out", str(seq)], env)
            rep = json.loads((seq / "report.json").read_text())
            fps = rep["computed"] / max(t - rep["geometry_seconds"] - rep["setup_seconds"], 1e-9)
            rp = {}
            for key, opts in (("hb", RPICT_HONEYBEE), ("ab5", RPICT_AB5)):
                if a.no_rpict_ab5 and key == "ab5":
                    rp[key] = float("nan")
                    continue
                with open(d / f"rpict-{key}.hdr", "wb") as f:
                    rp[key] = timed(["rpict", "-pa", "0", "-x", str(w), "-y", str(h)] + view.split()
                                    + v.two_sided(opts).split() + [str(octree)], env, stdout=f)
            print(f"| {name} | {label} | {runs['cold']:.1f} | {runs['warm']:.1f} | "
                  f"{fps:.2f} ({rep['computed']} frames, camera {rep['geometry_seconds']:.1f} s once) | "
                  f"{rp['hb']:.1f} | {rp['ab5']:.1f} |", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--daystep", default=str(REPO / "target/release/daystep"))
    ap.add_argument("--width", type=int, default=100)
    ap.add_argument("--height", type=int, default=75)
    ap.add_argument("--nproc", type=int, default=2)
    ap.add_argument("--only", choices=["perez", "overcast"])
    ap.add_argument("--gather", type=int, default=64)
    ap.add_argument("--reference", default=REFERENCE)
    ap.add_argument("--speed", action="store_true",
                    help="instead: seconds per 800×600 and 1000×1000 frame, cold and warm, "
                         "a warm sequence's frames per second, against rpict")
    ap.add_argument("--no-rpict-ab5", action="store_true", help="with --speed: skip rpict -ab 5")
    a = ap.parse_args()
    env, _, _ = v.radiance_env()
    if a.speed:
        speed(a, env)
        return
    work = REPO / "target/render-bench"
    work.mkdir(parents=True, exist_ok=True)
    scene_path = REPO / "scenes/office/scene.toml"
    sc = tomllib.loads(scene_path.read_text())
    rho_g = float(sc.get("ground_reflectance", 0.2))
    site = sc["site"]
    lat, lon, tz = float(site["latitude"]), float(site["longitude"]), float(site["utc_offset_h"])
    tris, mats = v.read_obj(scene_path.parent / sc["geometry"], "z", 0.0)
    v.write_radiance_scene(tris, mats, work / "scene.rad")
    site_opts = ["-a", f"{lat}", "-o", f"{-lon}", "-m", f"{-15.0 * tz:g}"]
    instants = [
        ("perez", ["gendaylit", "3", "21", "11.5", "-y", "2024"] + site_opts
         + ["-W", "978", "86", "-g", f"{rho_g}"],
         ["--time", "2024-03-21T11:30", "--sky", "perez", "--dni", "978", "--dhi", "86",
          "--dew-point", "10.974"]),
        ("overcast", ["gensky", "3", "21", "12", "-y", "2024", "-c", "-B", "100"] + site_opts
         + ["-g", f"{rho_g}"],
         ["--time", "2024-03-21T12:00", "--sky", "cie-overcast", "--dhi", "100"]),
    ]
    w, h = a.width, a.height
    print(f"{w}×{h} pixels; reference `rtrace {a.reference}` per pixel centre; daystep "
          f"`--gather {a.gather}`, default quality, {a.nproc} threads")
    print()
    for key, skycmd, dsargs in instants:
        if a.only and a.only != key:
            continue
        d = work / key
        octree = v.sky_octree(d, skycmd, ["../scene.rad"], env)
        for vname, view in (("toward the window", VIEW), ("toward the back wall", VIEW_BACK)):
            compare_view(a, env, d, key, skycmd, dsargs, vname, view, scene_path, octree)


def compare_view(a, env, d, key, skycmd, dsargs, vname, view, scene_path, octree):
    """One instant and camera: region means of the reference, of rpict and of daystep."""
    w, h = a.width, a.height
    d = d / ("window" if view == VIEW else "back")
    d.mkdir(exist_ok=True)
    rays = pixel_rays(w, h, env, d, view)
    px = classify(octree, rays, env, d)
    direct, _ = rtrace_values(octree, rays, "-ab 0 -dj 0 -dt 0 -dc 1 -st 0", env, a.nproc, d)
    reg = regions(px, direct, w, h)
    ref, ref_s = rtrace_values(octree, rays, a.reference, env, a.nproc, d)
    times = {"reference rtrace (per pixel centre)": ref_s}
    images = {}
    for name, opts in (("rpict -ab 5", RPICT_AB5), ("rpict Honeybee", RPICT_HONEYBEE)):
        t0 = time.perf_counter()
        path = d / f"rpict-{name.split()[-1]}.hdr"
        with open(path, "wb") as f:
            subprocess.run(["rpict", "-pa", "0", "-x", str(w), "-y", str(h)] + view.split()
                           + v.two_sided(opts).split() + [str(octree)], env=env, stdout=f,
                           check=True)
        times[name] = time.perf_counter() - t0
        images[name] = read_hdr_values(path, env)
    # daystep, cold then warm.
    cache = d / "cache"
    if cache.exists():
        shutil.rmtree(cache)
    for run in ("cold", "warm"):
        out = d / f"daystep-{run}"
        if out.exists():
            shutil.rmtree(out)
        cmd = [a.daystep, "render", str(scene_path), "--view", view, "-x", str(w), "-y", str(h),
               "--gather", str(a.gather), "--hdr", "--out", str(out), "--cache", str(cache),
               "--threads", str(a.nproc)] + dsargs
        t0 = time.perf_counter()
        v.run(cmd, env)
        times[f"daystep {run}"] = time.perf_counter() - t0
        if run == "warm":
            images["daystep"] = read_hdr_values(next(out.glob("*.hdr")), env)
    print(f"## {key}, {vname}: `{' '.join(skycmd)}`, view `{view}`")
    print()
    names = list(images)
    print("| region | pixels | reference cd/m² | " + " | ".join(names) + " |")
    print("|---|---|---|" + "---|" * len(names))
    for name, idx in reg.items():
        if len(idx) < 20:
            continue
        r = sum(ref[i] for i in idx) / len(idx)
        cells = []
        for n in names:
            g = sum(images[n][i] for i in idx) / len(idx)
            cells.append(f"{g:.1f} ({100 * (g - r) / r:+.1f} %)")
        print(f"| {name} | {len(idx)} | {r:.1f} | " + " | ".join(cells) + " |")
    print()
    print("| run | seconds |")
    print("|---|---|")
    for k, t in times.items():
        print(f"| {k} | {t:.1f} |")
    print(flush=True)


if __name__ == "__main__":
    main()
