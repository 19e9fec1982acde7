#!/usr/bin/env python3
"""Validation of daystep against Radiance on the sample office or another scene (not part of `cargo test`).

Run it through `tests/bench/radiance/run.sh`, which makes the virtual environment with
pyradiance (the Radiance binaries and their lib folder come inside its wheel) and builds
daystep. By hand:

    target/radiance-venv/bin/python tests/bench/radiance/validate.py [--quick]
        [--scene tests/bench/radiance/courtyard/scene.toml] [--only perez] [--nproc 1]

What it does, for each instant (a Perez sky with sun, a CIE overcast sky):
  1. converts the scene (scene.toml, OBJ, MTL, .pts) to Radiance: `Kd` -> plastic,
     `Tf` -> glass (Radiance's transmittance -> transmissivity conversion), `Ke` -> light;
     polygons fan-triangulated as daystep does; `up` and `north_deg` applied as daystep does;
     plastic reflects from both faces, and every rtrace run states -bv+ (back faces
     visible, Radiance's default) so that no setting can make single-surface walls
     one-sided; a trailing `# group` comment on a .pts line names the sensor's group;
  2. makes the sky with gendaylit / gensky (ground glow with the scene's ground reflectance);
  3. runs rtrace -I at the .pts sensors: a converged path-traced reference (no irradiance
     cache), the same at half the samples (to estimate the reference's own noise), a
     middle and a common setting; plus two direct-only runs (every opaque surface black) to
     split the reference into sun, sky and interreflected parts;
  4. runs `daystep instant` at --quality draft, default, high, cold (--no-cache);
  5. prints one markdown table per instant: wall time, differences to the reference over
     sensors above 10 lx, and for daystep its own stated error (lux_err); a summary line
     (daystep default's RMS and its coverage, |daystep - reference| <= lux_err, against the
     target of <= 3 % and >= 90 %) and, when the .pts names groups, the same by group; then
     the parts (sun, sky, interreflected) and, without groups, the differences by sensor row.
With --annual, also a year of the bundled weather file: Radiance 2-phase daylight
coefficients (gendaymtx + rfluxmtx + dctimestep) against `daystep annual`, compared by
DA300, sDA, UDI and hour by hour.
With --two-phase-only (called by `cargo bench --bench annual`, the speed bench of issue 14),
only Radiance's 2-phase on --scene and --weather (optionally --start/--end MM-DD): the
scene conversion, epw2wea, gendaymtx, rfluxmtx (-ab 5 -ad 10000 -lw 1e-5, or --dc-opts),
dctimestep, rmtxop, each stage timed and its memory sampled; the metrics as --annual
computes them; all written to --json (the illuminance to illuminance.f32 beside it).

Standard library only (plus the pyradiance wheel for its binaries). Radiance is called as
command-line programs via subprocess.
"""

import argparse
import datetime
import json
import math
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
LUX_MIN = 10.0  # sensors below this (in the reference) are left out of the statistics


# --------------------------------------------------------------------------------------
# Radiance from the pyradiance wheel
# --------------------------------------------------------------------------------------

def radiance_env():
    """PATH and RAYPATH for the binaries shipped in the pyradiance wheel."""
    import pyradiance  # noqa: F401  (only to find the wheel's folders)

    base = Path(pyradiance.__file__).resolve().parent
    bindir, libdir = base / "bin", base / "lib"
    if not (bindir / "rtrace").exists():
        sys.exit(f"no rtrace in {bindir}: is this the pyradiance wheel with binaries?")
    env = dict(os.environ)
    env["PATH"] = f"{bindir}{os.pathsep}{env.get('PATH', '')}"
    env["RAYPATH"] = f".{os.pathsep}{libdir}"
    return env, bindir, libdir


def run(cmd, env, stdin=None, cwd=None):
    """Runs `cmd` (a list), returns stdout as text; fails loudly with stderr."""
    p = subprocess.run(cmd, env=env, input=stdin, cwd=cwd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"command failed ({p.returncode}): {' '.join(map(str, cmd))}\n{p.stderr}")
    return p.stdout


# --------------------------------------------------------------------------------------
# Scene conversion
# --------------------------------------------------------------------------------------

def glass_transmissivity(tn):
    """Radiance `glass` transmissivity for normal-incidence transmittance tn (n = 1.52)."""
    if tn <= 0.0:
        return 0.0
    return (math.sqrt(0.8402528435 + 0.0072522239 * tn * tn) - 0.9166530661) / 0.0036261119 / tn


def read_mtl(path):
    mats, cur = {}, None
    for raw in path.read_text().splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        key, *rest = line.split()
        k = key.lower()
        if k == "newmtl":
            cur = " ".join(rest)
            mats[cur] = {"kd": (0.0, 0.0, 0.0), "tf": (0.0, 0.0, 0.0), "ke": (0.0, 0.0, 0.0)}
        elif k in ("kd", "tf", "ke") and cur is not None:
            vals = [float(v) for v in rest[:3]]
            if len(vals) == 1:
                vals = vals * 3
            mats[cur][k] = tuple(vals)
    return mats


def to_scene_frame(p, up, north_deg):
    """Model point -> daystep's scene frame (x east, y north, z up), as src/scene does,
    without its shift to a local origin (sensors.csv reports model coordinates)."""
    x, y, z = p
    if up == "y":
        x, y, z = x, -z, y
    s, c = math.sin(math.radians(north_deg)), math.cos(math.radians(north_deg))
    return (c * x - s * y, s * x + c * y, z)


def read_obj(path, up, north_deg):
    """Triangles (v0, v1, v2, material) in the scene frame, and the MTL materials."""
    verts, tris, mats, cur = [], [], {}, None
    for raw in path.read_text().splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        key, *rest = line.split()
        if key == "v":
            x, y, z = (float(v) for v in rest[:3])
            if len(rest) > 3:  # homogeneous w, as tobj reads it
                w = float(rest[3])
                x, y, z = x / w, y / w, z / w
            verts.append(to_scene_frame((x, y, z), up, north_deg))
        elif key == "mtllib":
            for name in rest:
                mats.update(read_mtl(path.parent / name))
        elif key == "usemtl":
            cur = " ".join(rest)
        elif key == "f":
            idx = []
            for tok in rest:
                i = int(tok.split("/")[0])
                idx.append(i - 1 if i > 0 else len(verts) + i)
            for k in range(1, len(idx) - 1):  # fan, as daystep (tobj) triangulates
                tris.append((verts[idx[0]], verts[idx[k]], verts[idx[k + 1]], cur))
    return tris, mats


def read_pts(path, up, north_deg):
    """(model point, scene-frame point, scene-frame direction) per sensor, and each
    sensor's group: the text of a trailing `# …` comment on its line (None without one;
    daystep skips such comments too, and rtrace is given the numbers only)."""
    out, groups = [], []
    for raw in path.read_text().splitlines():
        body, _, comment = raw.partition("#")
        f = body.split()
        if len(f) < 6:
            continue
        p = to_scene_frame(tuple(map(float, f[:3])), up, north_deg)
        d = to_scene_frame(tuple(map(float, f[3:6])), up, north_deg)
        out.append((tuple(map(float, f[:3])), p, d))
        groups.append(comment.strip() or None)
    return out, groups


def radname(name):
    return "m_" + "".join(ch if ch.isalnum() or ch in "_-." else "_" for ch in name)


NONREFLECTING_CAL = """{ Radiance glass's transmittance without its reflection (a diagnostic):
  the glass.c formula for refractive index 1.52 and transmissivity tn at cos = |Rdot|. }
gn = 1.52;
gci = max(abs(Rdot), 1e-6);
gct = sqrt(1 - (1 - gci*gci)/(gn*gn));
gre = sq((gci - gn*gct)/(gci + gn*gct));
grm = sq((1/gci - gn/gct)/(1/gci + gn/gct));
gtau(tn) = .5*sq(1-gre)*tn^(1/gct)/(1-gre*gre*tn^(2/gct))
         + .5*sq(1-grm)*tn^(1/gct)/(1-grm*grm*tn^(2/gct));
"""


def write_radiance_scene(tris, mats, path, black=False, glazing="glass"):
    """Materials and polygons. black=True: every opaque surface reflects nothing (glass and
    light stay), for the direct-only runs. glazing="nonreflecting": panes are a BRTDfunc
    with glass's angular transmittance and no reflection (isolates glazing reflection)."""
    used = sorted({t[3] for t in tris})
    lines = ["# converted from the daystep scene by tests/bench/radiance/validate.py"]
    for name in used:
        m = mats.get(name, {"kd": (0.0,) * 3, "tf": (0.0,) * 3, "ke": (0.0,) * 3})
        rn = radname(name)
        if max(m["ke"]) > 0:
            lines.append(f"void light {rn}\n0\n0\n3 {m['ke'][0]} {m['ke'][1]} {m['ke'][2]}")
        elif max(m["tf"]) > 0:
            t = [glass_transmissivity(v) for v in m["tf"]]
            if glazing == "nonreflecting":
                cal = path.parent / "nonreflecting.cal"
                cal.write_text(NONREFLECTING_CAL)
                tr = " ".join(f"gtau({v:.6f})" for v in t)
                lines.append(f"void BRTDfunc {rn}\n10 0 0 0 {tr} 0 0 0 {cal}\n0\n"
                             "9 0 0 0 0 0 0 0 0 0")
            else:
                lines.append(f"void glass {rn}\n0\n0\n3 {t[0]:.6f} {t[1]:.6f} {t[2]:.6f}")
        else:
            kd = (0.0, 0.0, 0.0) if black else m["kd"]
            lines.append(f"void plastic {rn}\n0\n0\n5 {kd[0]} {kd[1]} {kd[2]} 0 0")
    for i, (a, b, c, name) in enumerate(tris):
        coords = " ".join(f"{v:.9g}" for p in (a, b, c) for v in p)
        lines.append(f"{radname(name)} polygon t{i}\n0\n0\n9 {coords}")
    path.write_text("\n".join(lines) + "\n")


def glow_lines():
    return (
        "skyfunc glow sky_glow\n0\n0\n4 1 1 1 0\nsky_glow source sky\n0\n0\n4 0 0 1 180\n"
        "skyfunc glow ground_glow\n0\n0\n4 1 1 1 0\nground_glow source ground\n0\n0\n4 0 0 -1 180\n"
    )


# --------------------------------------------------------------------------------------
# Running the tools
# --------------------------------------------------------------------------------------

def lux_of_rgb(line):
    r, g, b = (float(v) for v in line.split()[:3])
    return 179.0 * (0.265 * r + 0.670 * g + 0.065 * b)


def two_sided(opts):
    """Radiance's surfaces reflect from both faces when back faces are visible (-bv, on by
    default; a bare `-bv` toggles it). Every run states -bv+ and no setting may change it:
    the scenes have single-surface walls lit on their back faces."""
    if any(o.startswith("-bv") for o in opts.split()):
        sys.exit(f"Radiance settings must not set -bv (back faces stay visible): {opts}")
    return "-bv+ " + opts


def rtrace(octree, pts_text, opts, env, nproc):
    cmd = ["rtrace", "-I", "-h", "-w", "-n", str(nproc)] + two_sided(opts).split() + [str(octree)]
    t0 = time.perf_counter()
    out = run(cmd, env, stdin=pts_text)
    secs = time.perf_counter() - t0
    print(f"  rtrace {opts}: {secs:.1f} s", file=sys.stderr, flush=True)
    vals = [lux_of_rgb(l) for l in out.splitlines() if l.strip()]
    if len(vals) != len(pts_text.splitlines()):
        sys.exit(f"rtrace gave {len(vals)} values for {len(pts_text.splitlines())} sensors")
    return vals, secs, " ".join(cmd[:-1]) + " OCTREE < sensors.pts"


def read_sensors_csv(path):
    rows = []
    lines = path.read_text().splitlines()
    head = lines[0].split(",")
    def value(v):
        try:
            return float(v)
        except ValueError:
            return v  # the `grid` column of a model with sensor grids
    for l in lines[1:]:
        rows.append(dict(zip(head, (value(v) for v in l.split(",")))))
    return rows


def daystep_instant(exe, scene, args, out, quality, env, threads=None):
    if out.exists():
        shutil.rmtree(out)
    cmd = [str(exe), "instant", str(scene)] + args + ["--out", str(out), "--quality", quality,
                                                      "--no-cache"]
    if threads:
        cmd += ["--threads", str(threads)]
    t0 = time.perf_counter()
    run(cmd, env)
    secs = time.perf_counter() - t0
    report = json.loads((out / "report.json").read_text())
    return read_sensors_csv(out / "sensors.csv"), secs, report, cmd


# --------------------------------------------------------------------------------------
# Statistics and printing
# --------------------------------------------------------------------------------------

def daystep_open_sky(exe, work, site, rho_g, dsargs, env, threads=None):
    """daystep's sun and sky on an unobstructed horizontal sensor: a scene whose only
    triangle is tiny and far below the sensor."""
    d = work / "open"
    d.mkdir(exist_ok=True)
    (d / "open.obj").write_text("mtllib open.mtl\nv 100 100 -50\nv 100.1 100 -50\n"
                                "v 100 100.1 -50\nusemtl black\nf 1 2 3\n")
    (d / "open.mtl").write_text("newmtl black\nKd 0 0 0\n")
    (d / "open.pts").write_text("0 0 0 0 0 1\n")
    (d / "scene.toml").write_text(
        f'geometry = "open.obj"\nsensors = "open.pts"\nground_reflectance = {rho_g}\n\n[site]\n'
        + "".join(f"{k} = {v}\n" for k, v in site.items()))
    rows, _, _, _ = daystep_instant(exe, d / "scene.toml", dsargs, d / "out", "default", env,
                                    threads)
    return rows[0]


def compare(vals, ref, errs=None, ref_noise_rel=0.0):
    """Relative differences over sensors where the reference is above LUX_MIN."""
    rel, covered, stated = [], 0, []
    for k, r in enumerate(ref):
        if r <= LUX_MIN:
            continue
        d = (vals[k] - r) / r
        rel.append(d)
        if errs is not None:
            stated.append(errs[k] / vals[k] if vals[k] > 0 else float("inf"))
            if abs(vals[k] - r) <= errs[k] + 2.0 * ref_noise_rel * r:
                covered += 1
    n = len(rel)
    out = {
        "n": n,
        "bias": 100 * sum(rel) / n,
        "mean": 100 * sum(abs(d) for d in rel) / n,
        "rms": 100 * math.sqrt(sum(d * d for d in rel) / n),
        "max": 100 * max(abs(d) for d in rel),
    }
    if errs is not None:
        out["stated"] = 100 * statistics.median(stated)
        out["covered"] = 100 * covered / n
    return out


def fmt_row(label, secs, c):
    stated = f"{c['stated']:.2f} %" if "stated" in c else "—"
    covered = f"{c['covered']:.0f} %" if "covered" in c else "—"
    t = f"{secs:.1f}" if secs >= 10 else f"{secs:.2f}"
    return (f"| {label} | {t} | {c['mean']:.2f} % | {c['bias']:+.2f} % | {c['rms']:.2f} % | "
            f"{c['max']:.1f} % | {stated} | {covered} |")


def machine_lines(env):
    cpu = "unknown"
    try:
        for l in Path("/proc/cpuinfo").read_text().splitlines():
            if l.startswith("model name"):
                cpu = l.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    from importlib.metadata import version
    rver = run(["rtrace", "-version"], env).strip()
    return [
        f"date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC",
        f"machine: {platform.machine()} ({run(['uname', '-m'], env).strip()}), CPU: {cpu}, "
        f"cores: {os.cpu_count()}",
        f"pyradiance {version('pyradiance')} ({rver}), Python {platform.python_version()}",
        "load average at start (1, 5, 15 min): " + ", ".join(f"{x:.2f}" for x in os.getloadavg()),
    ]


# --------------------------------------------------------------------------------------
# Main
# --------------------------------------------------------------------------------------

# Radiance settings. The reference is path traced (-aa 0: no irradiance cache, so no
# interpolation bias); -lr 0 with -lw: Russian roulette, so long paths end without a bounce
# limit biasing the result; -ab 16 keeps what -ab drops below the noise (measured: see docs/validation.md).
REFERENCE = "-ab 16 -aa 0 -as 0 -ad 32768 -lr 0 -lw 1e-6 -dj 0 -dt 0 -dc 1 -st 0"
REFERENCE_HALF = "-ab 16 -aa 0 -as 0 -ad 16384 -lr 0 -lw 1e-6 -dj 0 -dt 0 -dc 1 -st 0"
QUICK_REFERENCE = "-ab 12 -aa 0 -as 0 -ad 8192 -lr 0 -lw 1e-5 -dj 0 -dt 0 -dc 1 -st 0"
QUICK_REFERENCE_HALF = "-ab 12 -aa 0 -as 0 -ad 4096 -lr 0 -lw 1e-5 -dj 0 -dt 0 -dc 1 -st 0"
DIRECT_SUN = "-ab 0 -dj 0 -dt 0 -dc 1 -st 0"
DIRECT_SKY = "-ab 1 -aa 0 -as 0 -ad 65536 -lw 1e-7 -dj 0 -dt 0 -dc 1 -st 0"
RADIANCE_ROWS = [
    ("Radiance -ab 5 (detailed settings)", "-ab 5 -ad 4096 -as 2048 -aa 0.1 -ar 256 -lw 1e-4"),
    ("Radiance -ab 2 (common settings)", "-ab 2 -ad 1024 -as 512 -aa 0.2 -ar 64"),
]


def read_matrix_ascii(text):
    """Rows of numbers after a Radiance header (ends with a blank line)."""
    lines = text.splitlines()
    if lines and lines[0].startswith("#?RADIANCE"):
        lines = lines[lines.index("") + 1:]
    return [[float(v) for v in l.split()] for l in lines if l.strip()]


def annual_metrics(table, hours):
    """table[t][s] lux, hours[t] = local standard hour at the record's middle.
    Occupied: hours starting 8:00 … 17:00 (daystep's and honeybee's default)."""
    occ = [t for t, h in enumerate(hours) if 8 <= math.floor(h) <= 17]
    ns = len(table[0])
    da = [sum(1 for t in occ if table[t][s] >= 300) / len(occ) for s in range(ns)]
    udi = [sum(1 for t in occ if 100 <= table[t][s] <= 3000) / len(occ) for s in range(ns)]
    return {
        "DA300 mean": 100 * statistics.mean(da),
        "sDA300/50%": 100 * sum(1 for v in da if v >= 0.5) / ns,
        "UDI100-3000 mean": 100 * statistics.mean(udi),
        "mean occupied lux": statistics.mean(table[t][s] for t in occ for s in range(ns)),
    }, occ


# 2-phase daylight coefficients: Tregenza/Reinhart MF:1 (145 sky patches + ground), path
# traced by rcontrib (-aa 0 is forced there).
DC_OPTS = "-ab 8 -ad 16384 -as 0 -lw 1e-5"


def annual_study(a, env, exe, scene_path, work, pts_text, rho_g):
    """Optional: a year of the bundled weather file, Radiance 2-phase (rfluxmtx + gendaymtx
    + dctimestep) against `daystep annual`, both on the same WEA (epw2wea of the EPW)."""
    d = work / "annual"
    d.mkdir(exist_ok=True)
    wea = d / "weather.wea"
    run(["epw2wea", str(a.weather), str(wea)], env)
    (d / "receiver.rad").write_text(
        "#@rfluxmtx h=u u=Y\nvoid glow ground_glow\n0\n0\n4 1 1 1 0\n"
        "ground_glow source ground\n0\n0\n4 0 0 -1 180\n"
        "#@rfluxmtx h=r1 u=Y\nvoid glow sky_glow\n0\n0\n4 1 1 1 0\n"
        "sky_glow source sky\n0\n0\n4 0 0 1 180\n")
    g = f"{rho_g}"
    t0 = time.perf_counter()
    skymtx = run(["gendaymtx", "-m", "1", "-g", g, g, g, str(wea)], env)
    (d / "sky.mtx").write_text(skymtx)
    t_sky = time.perf_counter() - t0
    t0 = time.perf_counter()
    dc = run(["rfluxmtx", "-I+", "-n", str(a.nproc)] + DC_OPTS.split()
             + ["-faa", "-", "receiver.rad", str(work / "scene.rad")], env, stdin=pts_text, cwd=d)
    t_dc = time.perf_counter() - t0
    (d / "dc.mtx").write_text(dc)
    t0 = time.perf_counter()
    ts = subprocess.run(["dctimestep", "dc.mtx", "sky.mtx"], env=env, cwd=d, capture_output=True,
                        check=True).stdout
    (d / "ts.mtx").write_bytes(ts)
    ill = run(["rmtxop", "-fa", "-t", "-c", "47.435", "119.93", "11.635", "ts.mtx"], env, cwd=d)
    t_ts = time.perf_counter() - t0
    rad = read_matrix_ascii(ill)  # rows: timesteps, columns: sensors
    hours = []
    for l in wea.read_text().splitlines()[6:]:
        f = l.split()
        if len(f) >= 5:
            hours.append(float(f[2]))

    out = d / "daystep"
    if out.exists():
        shutil.rmtree(out)
    cmd = [str(exe), "annual", str(scene_path), "--weather", str(wea), "--out", str(out),
           "--no-cache"]
    t0 = time.perf_counter()
    run(cmd, env)
    t_ds = time.perf_counter() - t0
    rows = (out / "illuminance.csv").read_text().splitlines()[1:]
    dst = [[float(v) for v in r.split(",")[1:]] for r in rows]
    if len(dst) != len(rad) or len(dst[0]) != len(rad[0]):
        print(f"annual: shapes differ (daystep {len(dst)}×{len(dst[0])}, "
              f"Radiance {len(rad)}×{len(rad[0])}): not compared")
        return
    m_rad, occ = annual_metrics(rad, hours)
    m_ds, _ = annual_metrics(dst, hours)
    rel = [(dst[t][s] - rad[t][s]) / rad[t][s] for t in occ for s in range(len(rad[0]))
           if rad[t][s] > 100]
    print("## A year of the bundled weather file (2-phase daylight coefficients)")
    print()
    print(f"weather: `epw2wea` of the EPW, {len(hours)} records, both tools read the same WEA "
          "(dew point 11 °C in both).")
    print()
    print("| | wall s | DA300 mean | sDA300/50% | UDI100-3000 mean | mean occupied lux |")
    print("|---|---|---|---|---|---|")
    for label, secs, m in (("Radiance 2-phase (MF:1, " + DC_OPTS + ")", t_sky + t_dc + t_ts, m_rad),
                           ("daystep annual, default, cold", t_ds, m_ds)):
        print(f"| {label} | {secs:.0f} | {m['DA300 mean']:.1f} % | {m['sDA300/50%']:.1f} % | "
              f"{m['UDI100-3000 mean']:.1f} % | {m['mean occupied lux']:.0f} |")
    print()
    print(f"Occupied sensor-hours with Radiance > 100 lx ({len(rel)}): daystep − Radiance "
          f"mean {100 * statistics.mean(rel):+.1f} %, mean |rel.| "
          f"{100 * statistics.mean(abs(x) for x in rel):.1f} %, RMS "
          f"{100 * math.sqrt(statistics.mean(x * x for x in rel)):.1f} % (Radiance times: "
          f"gendaymtx {t_sky:.0f} s, rfluxmtx {t_dc:.0f} s, dctimestep + rmtxop {t_ts:.0f} s).")
    print()
    print(f"- `gendaymtx -m 1 -g {g} {g} {g} weather.wea > sky.mtx`")
    print(f"- `rfluxmtx -I+ -n {a.nproc} {DC_OPTS} -faa - receiver.rad scene.rad < office.pts > dc.mtx`")
    print("- `dctimestep dc.mtx sky.mtx | rmtxop -fa -t -c 47.435 119.93 11.635 -`")
    print(f"- `{' '.join(cmd)}`")
    print()


# --------------------------------------------------------------------------------------
# The speed bench's 2-phase run (--two-phase-only, called by `cargo bench --bench annual`)
# --------------------------------------------------------------------------------------

# The speed bench's daylight-coefficient settings (issue 14): a common 2-phase setting,
# lighter than DC_OPTS above (the validation's).
BENCH_DC_OPTS = "-ab 5 -ad 10000 -lw 1e-5"


def tree_memory_kb(root):
    """Resident memory of process `root` and its descendants, from /proc: (VmRSS summed
    over the processes, the largest process's VmHWM), kB."""
    children = {}
    for p in os.listdir("/proc"):
        if not p.isdigit():
            continue
        try:
            with open(f"/proc/{p}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        children.setdefault(ppid, []).append(int(p))
    rss, hwm, todo = 0, 0, [root]
    while todo:
        pid = todo.pop()
        try:
            with open(f"/proc/{pid}/status") as f:
                for l in f:
                    if l.startswith("VmRSS:"):
                        rss += int(l.split()[1])
                    elif l.startswith("VmHWM:"):
                        hwm = max(hwm, int(l.split()[1]))
        except (OSError, ValueError, IndexError):
            pass
        todo.extend(children.get(pid, []))
    return rss, hwm


def run_measured(name, cmd, env, cwd, stdin=None, stdout=None):
    """Runs one Radiance stage with stdin/stdout redirected to files. Returns (wall s, peak
    resident memory of its largest process, MB, peak resident memory summed over the
    process and its descendants, MB). Memory is sampled from /proc every 0.1 s (VmHWM for
    the first figure, so a process's own peak counts if it is alive at a sample; a stage
    shorter than that may read 0). Not getrusage: a child's ru_maxrss starts at the
    forking Python's size."""
    import threading

    fin = open(stdin, "rb") if stdin else subprocess.DEVNULL
    fout = open(stdout, "wb") if stdout else subprocess.DEVNULL
    err_path = Path(cwd) / f"{name}.stderr"
    ferr = open(err_path, "wb")
    t0 = time.perf_counter()
    p = subprocess.Popen([str(c) for c in cmd], env=env, cwd=cwd, stdin=fin, stdout=fout,
                         stderr=ferr)
    peak, done = [0, 0], threading.Event()

    def sample():
        while not done.is_set():
            rss, hwm = tree_memory_kb(p.pid)
            peak[0], peak[1] = max(peak[0], rss), max(peak[1], hwm)
            done.wait(0.1)

    th = threading.Thread(target=sample, daemon=True)
    th.start()
    p.wait()
    secs = time.perf_counter() - t0
    done.set()
    th.join()
    for f in (fin, fout, ferr):
        if f is not subprocess.DEVNULL:
            f.close()
    if p.returncode != 0:
        sys.exit(f"command failed ({p.returncode}): {' '.join(map(str, cmd))}\n"
                 f"{err_path.read_text(errors='replace')}")
    print(f"  {name}: {secs:.1f} s", file=sys.stderr, flush=True)
    return secs, peak[1] / 1024.0, max(peak) / 1024.0


def read_float_matrix(path):
    """A Radiance matrix in binary float (header, blank line, data): (rows, cols, comps,
    array of float32)."""
    from array import array

    data = path.read_bytes()
    end = data.index(b"\n\n") + 2
    head = dict(l.split("=", 1) for l in data[:end].decode(errors="replace").splitlines()
                if "=" in l)
    if head.get("FORMAT", "").strip() != "float":
        sys.exit(f"{path}: FORMAT={head.get('FORMAT')}, expected float")
    nr, nc = int(head["NROWS"]), int(head["NCOLS"])
    ncomp = int(head.get("NCOMP", "1"))
    arr = array("f")
    arr.frombytes(data[end:end + 4 * nr * nc * ncomp])
    if len(arr) != nr * nc * ncomp:
        sys.exit(f"{path}: {len(arr)} values, the header says {nr}×{nc}×{ncomp}")
    order = head.get("BYTEORDER", "").strip()
    if order and (order == "LSB") != (sys.byteorder == "little"):
        arr.byteswap()
    return nr, nc, ncomp, arr


def month_day(text):
    m, d = (int(v) for v in text.split("-"))
    return m, d


def two_phase_only(a):
    """The 2-phase year (or period) of the speed bench: converts the scene, runs epw2wea,
    gendaymtx -m 1, rfluxmtx, dctimestep, rmtxop (binary float matrices), times each stage
    and measures its memory, computes DA/sDA/UDI with the occupancy daystep uses
    (annual_metrics) and writes it all to --json; the illuminance (timesteps × sensors,
    native float32) to illuminance.f32 beside it."""
    env, bindir, _ = radiance_env()
    scene_path = Path(a.scene).resolve()
    work = Path(a.work) if a.work else REPO / "target/bench-annual/radiance" / scene_path.parent.name
    work.mkdir(parents=True, exist_ok=True)
    opts = a.dc_opts or BENCH_DC_OPTS
    t_all = time.perf_counter()

    # Scene, as the validation converts it.
    t0 = time.perf_counter()
    sc = tomllib.loads(scene_path.read_text())
    up, north = sc.get("up", "z"), float(sc.get("north_deg", 0.0))
    rho_g = float(sc.get("ground_reflectance", 0.2))
    tris, mats = read_obj(scene_path.parent / sc["geometry"], up, north)
    sensors, _ = read_pts(scene_path.parent / sc["sensors"], up, north)
    write_radiance_scene(tris, mats, work / "scene.rad")
    (work / "sensors.pts").write_text("".join(
        f"{p[0]:.9g} {p[1]:.9g} {p[2]:.9g} {d[0]:.9g} {d[1]:.9g} {d[2]:.9g}\n"
        for _, p, d in sensors))
    (work / "receiver.rad").write_text(
        "#@rfluxmtx h=u u=Y\nvoid glow ground_glow\n0\n0\n4 1 1 1 0\n"
        "ground_glow source ground\n0\n0\n4 0 0 -1 180\n"
        "#@rfluxmtx h=r1 u=Y\nvoid glow sky_glow\n0\n0\n4 1 1 1 0\n"
        "sky_glow source sky\n0\n0\n4 0 0 1 180\n")
    t_convert = time.perf_counter() - t0

    stages, commands = [], []

    def stage(name, cmd, stdin=None, stdout=None):
        secs, rss_proc, rss_tree = run_measured(name, cmd, env, work, stdin, stdout)
        stages.append({"stage": name, "seconds": secs, "rss_process_mb": rss_proc,
                       "rss_tree_mb": rss_tree})
        cmd_text = " ".join(str(c) for c in cmd)
        if stdin:
            cmd_text += f" < {Path(stdin).name}"
        if stdout:
            cmd_text += f" > {Path(stdout).name}"
        commands.append(cmd_text)

    g = f"{rho_g}"
    t_rad = time.perf_counter()
    stage("epw2wea", ["epw2wea", Path(a.weather).resolve(), "weather_full.wea"])
    # The period: the WEA rows from --start to --end (month-day, inclusive).
    lines = (work / "weather_full.wea").read_text().splitlines()
    head, rows = lines[:6], [l for l in lines[6:] if len(l.split()) >= 5]
    lo = month_day(a.start) if a.start else (1, 1)
    hi = month_day(a.end) if a.end else (12, 31)
    rows = [l for l in rows if lo <= (int(l.split()[0]), int(l.split()[1])) <= hi]
    if not rows:
        sys.exit(f"no weather rows from {lo} to {hi}")
    (work / "weather.wea").write_text("\n".join(head + rows) + "\n")
    stage("gendaymtx", ["gendaymtx", "-m", "1", "-of", "-g", g, g, g, "weather.wea"],
          stdout=work / "sky.mtx")
    stage("rfluxmtx", ["rfluxmtx", "-I+", "-n", str(a.nproc)] + opts.split()
          + ["-faf", "-", "receiver.rad", "scene.rad"],
          stdin=work / "sensors.pts", stdout=work / "dc.mtx")
    stage("dctimestep", ["dctimestep", "-of", "dc.mtx", "sky.mtx"], stdout=work / "ts.mtx")
    stage("rmtxop", ["rmtxop", "-ff", "-t", "-c", "47.435", "119.93", "11.635", "ts.mtx"],
          stdout=work / "ill.mtx")
    t_rad = time.perf_counter() - t_rad
    (work / "ts.mtx").unlink()  # timesteps × sensors × RGB: the largest file, not needed

    nr, nc, ncomp, arr = read_float_matrix(work / "ill.mtx")
    if ncomp != 1 or nr != len(rows) or nc != len(sensors):
        sys.exit(f"ill.mtx is {nr}×{nc}×{ncomp}, expected {len(rows)}×{len(sensors)}×1")
    ill_path = Path(a.json).with_name("illuminance.f32") if a.json else work / "illuminance.f32"
    with open(ill_path, "wb") as f:
        arr.tofile(f)
    times = [[int(l.split()[0]), int(l.split()[1]), float(l.split()[2])] for l in rows]
    table = [arr[t * nc:(t + 1) * nc] for t in range(nr)]
    metrics, occ = annual_metrics(table, [h for _, _, h in times])

    from importlib.metadata import version
    out = {
        "scene": str(scene_path),
        "weather": str(Path(a.weather).resolve()),
        "triangles": len(tris),
        "sensors": len(sensors),
        "timesteps": nr,
        "occupied_steps": len(occ),
        "times": times,
        "dc_opts": opts,
        "nproc": a.nproc,
        "pyradiance": version("pyradiance"),
        "radiance": run(["rtrace", "-version"], env).strip(),
        "convert_seconds": t_convert,
        "radiance_seconds": t_rad,
        "wall_seconds": time.perf_counter() - t_all,
        "rss_process_mb": max(s["rss_process_mb"] for s in stages),
        "rss_tree_mb": max(s["rss_tree_mb"] for s in stages),
        "stages": stages,
        "commands": commands,
        "metrics": metrics,
        "illuminance_f32": str(ill_path),
        "work": str(work),
    }
    text = json.dumps(out, indent=1)
    if a.json:
        Path(a.json).write_text(text + "\n")
    else:
        print(text)
    return 0


# The outdoor bench's target for daystep default (docs/validation.md, "Outdoors").
TARGET_RMS, TARGET_COVERAGE = 3.0, 90.0


def summary(ds, ref, ref_ind, groups, ref_noise):
    """daystep default against the reference: RMS and coverage (|daystep − reference| ≤
    lux_err, nothing added for the reference's noise) over sensors above LUX_MIN; by group
    when the .pts names groups."""
    def stats(ks, q):
        rows = ds[q][0]
        ks = [k for k in ks if ref[k] > LUX_MIN]
        rel = [(rows[k]["lux"] - ref[k]) / ref[k] for k in ks]
        cov = sum(1 for k in ks if abs(rows[k]["lux"] - ref[k]) <= rows[k]["lux_err"])
        cov2 = sum(1 for k in ks if abs(rows[k]["lux"] - ref[k])
                   <= rows[k]["lux_err"] + 2.0 * ref_noise * ref[k])
        return {
            "n": len(ks),
            "rms": 100 * math.sqrt(sum(d * d for d in rel) / len(ks)),
            "bias": 100 * sum(rel) / len(ks),
            "cov": 100 * cov / len(ks),
            "cov2": 100 * cov2 / len(ks),
            "ref": statistics.mean(ref[k] for k in ks),
            "ref_ind": statistics.mean(ref_ind[k] for k in ks),
            "ds_ind": statistics.mean(rows[k]["lux_indirect"] for k in ks),
        }

    every = list(range(len(ref)))
    c = stats(every, "default")
    ok = c["rms"] <= TARGET_RMS and c["cov"] >= TARGET_COVERAGE
    print(f"**Summary, daystep default against the converged reference** ({c['n']} sensors "
          f"above {LUX_MIN:g} lx): RMS {c['rms']:.2f} %, bias {c['bias']:+.2f} %, coverage "
          f"{c['cov']:.0f} % (|daystep − reference| ≤ lux_err; {c['cov2']:.0f} % with 2σ of the "
          f"reference's noise added); target ≤ {TARGET_RMS:g} % RMS and ≥ "
          f"{TARGET_COVERAGE:g} % coverage: {'met' if ok else 'NOT met'}.")
    print()
    if not any(groups):
        return
    print("By sensor group (the .pts comments; reference and interreflected means in lux, "
          "differences relative, over sensors above 10 lx):")
    print()
    print("| group | sensors | reference | ref. interreflected | default interreflected | "
          "default bias | default RMS | default coverage | high RMS | high coverage |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for g in list(dict.fromkeys(groups)) + ["all"]:
        ks = every if g == "all" else [k for k in every if groups[k] == g]
        if not any(ref[k] > LUX_MIN for k in ks):
            continue
        c, h = stats(ks, "default"), stats(ks, "high")
        print(f"| {g or '(none)'} | {c['n']} | {c['ref']:.0f} | {c['ref_ind']:.0f} | "
              f"{c['ds_ind']:.0f} | {c['bias']:+.2f} % | {c['rms']:.2f} % | {c['cov']:.0f} % | "
              f"{h['rms']:.2f} % | {h['cov']:.0f} % |")
    print()


def sky_octree(d, skycmd, scene_files, env):
    """Writes d/sky.rad (the sky of `skycmd` with its ground glow) and d/scene.oct, the
    octree of that sky and `scene_files` (paths, or names relative to d); returns its path."""
    d.mkdir(parents=True, exist_ok=True)
    (d / "sky.rad").write_text(run(skycmd, env) + glow_lines())
    octree = d / "scene.oct"
    octree.write_bytes(subprocess.run(["oconv", "-f", "sky.rad"] + [str(f) for f in scene_files],
                                      env=env, cwd=d, capture_output=True, check=True).stdout)
    return octree


def instant_specs(lat, lon, tz, rho_g):
    """The two bench instants: (key, title, Radiance sky command, daystep arguments)."""
    # Radiance longitude is west-positive, the meridian too.
    ro, rm = -lon, -15.0 * tz
    site_opts = ["-a", f"{lat}", "-o", f"{ro}", "-m", f"{rm:g}"]
    return [
        ("perez", "Perez sky with sun, 2024-03-21 11:30 LST, DNI 978, DHI 86 W/m²",
         ["gendaylit", "3", "21", "11.5", "-y", "2024"] + site_opts
         + ["-W", "978", "86", "-g", f"{rho_g}"],
         ["--time", "2024-03-21T11:30", "--sky", "perez", "--dni", "978", "--dhi", "86",
          # gendaylit uses 2 cm of precipitable water; W = exp(0.07 Td - 0.075) = 2 cm at
          # Td = 10.974 °C (daystep's default, 11 °C, gives 2.004 cm).
          "--dew-point", "10.974"]),
        ("overcast", "CIE overcast, 2024-03-21 12:00 LST, DHI 100 W/m² (17 900 lx horizontal)",
         ["gensky", "3", "21", "12", "-y", "2024", "-c", "-B", "100"] + site_opts
         + ["-g", f"{rho_g}"],
         ["--time", "2024-03-21T12:00", "--sky", "cie-overcast", "--dhi", "100"]),
    ]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--daystep", default=str(REPO / "target/release/daystep"))
    ap.add_argument("--scene", default=str(REPO / "scenes/office/scene.toml"))
    ap.add_argument("--work", help="scratch folder (default target/radiance-bench for the "
                    "office, target/radiance-bench/NAME for another scene's folder NAME)")
    ap.add_argument("--nproc", type=int, default=os.cpu_count() or 1,
                    help="rtrace -n and daystep --threads (default: every core)")
    ap.add_argument("--quick", action="store_true",
                    help="small reference (a smoke test of the bench, not a validation)")
    ap.add_argument("--only", choices=["perez", "overcast"], help="one instant only")
    ap.add_argument("--annual", action="store_true",
                    help="also a year: Radiance 2-phase against daystep annual")
    ap.add_argument("--weather", default=str(REPO / "scenes/office/weather.epw"),
                    help="weather file of the --annual study (EPW)")
    ap.add_argument("--no-instants", action="store_true", help="skip the instants")
    ap.add_argument("--glazing", choices=["glass", "nonreflecting"], default="glass",
                    help="Radiance panes: glass (reflects 8 %% at normal incidence, more "
                         "at grazing; daystep models that too) or, as a diagnostic, a "
                         "BRTDfunc with glass's transmittance and no reflection")
    ap.add_argument("--two-phase-only", action="store_true",
                    help="only the speed bench's 2-phase run (`cargo bench --bench annual` "
                         "calls it): convert --scene, run gendaymtx/rfluxmtx/dctimestep/"
                         "rmtxop on --weather, time each stage, write --json")
    ap.add_argument("--json", help="with --two-phase-only: where to write the results")
    ap.add_argument("--start", help="with --two-phase-only: first day MM-DD (default 01-01)")
    ap.add_argument("--end", help="with --two-phase-only: last day MM-DD (default 12-31)")
    ap.add_argument("--dc-opts", help="with --two-phase-only: rfluxmtx settings instead of "
                    f"'{BENCH_DC_OPTS}'")
    a = ap.parse_args()
    if a.two_phase_only:
        return two_phase_only(a)

    env, bindir, libdir = radiance_env()
    exe = Path(a.daystep)
    if not exe.exists():
        sys.exit(f"{exe} not found: build daystep first (cargo build --release)")
    scene_path = Path(a.scene).resolve()
    if a.work:
        work = Path(a.work)
    elif scene_path == (REPO / "scenes/office/scene.toml").resolve():
        work = REPO / "target/radiance-bench"
    else:
        work = REPO / "target/radiance-bench" / scene_path.parent.name
    work.mkdir(parents=True, exist_ok=True)
    ref_opts, half_opts = (QUICK_REFERENCE, QUICK_REFERENCE_HALF) if a.quick else (
        REFERENCE, REFERENCE_HALF)

    for l in machine_lines(env):
        print(l)
    print(f"daystep: {run([str(exe), '--version'], env).strip()} ({exe})")
    print(f"Radiance: {bindir}, RAYPATH={env['RAYPATH']}")
    print()

    # ---- scene -------------------------------------------------------------------------
    sc = tomllib.loads(scene_path.read_text())
    up = sc.get("up", "z")
    north = float(sc.get("north_deg", 0.0))
    rho_g = float(sc.get("ground_reflectance", 0.2))
    site = sc["site"]
    lat, lon, tz = float(site["latitude"]), float(site["longitude"]), float(site["utc_offset_h"])
    tris, mats = read_obj(scene_path.parent / sc["geometry"], up, north)
    sensors, groups = read_pts(scene_path.parent / sc["sensors"], up, north)
    write_radiance_scene(tris, mats, work / "scene.rad", glazing=a.glazing)
    write_radiance_scene(tris, mats, work / "scene_black.rad", black=True, glazing=a.glazing)
    pts_text = "".join(f"{p[0]:.9g} {p[1]:.9g} {p[2]:.9g} {d[0]:.9g} {d[1]:.9g} {d[2]:.9g}\n"
                       for _, p, d in sensors)
    (work / "sensors.pts").write_text(pts_text)
    print(f"scene: {scene_path.relative_to(REPO) if scene_path.is_relative_to(REPO) else scene_path}"
          f", {len(tris)} triangles, {len(sensors)} sensors, up = {up}, north_deg = {north}, "
          f"ground reflectance {rho_g}")
    if any(groups):
        print("  sensor groups (trailing `# …` of the .pts lines): " + ", ".join(
            f"{g} {groups.count(g)}" for g in dict.fromkeys(groups)))
    print("  Radiance: plastic for every Kd (two-sided: back faces visible, -bv+ on every run)")
    for name, m in sorted(mats.items()):
        if max(m["tf"]) > 0:
            t = [glass_transmissivity(v) for v in m["tf"]]
            print(f"  {name}: Tf {m['tf'][0]} -> Radiance glass transmissivity {t[0]:.4f}")
    print()

    instants = instant_specs(lat, lon, tz, rho_g)
    qualities = ["draft", "default", "high"]

    for key, title, skycmd, dsargs in instants:
        if a.no_instants or (a.only and a.only != key):
            continue
        d = work / (key if a.glazing == "glass" else f"{key}-{a.glazing}")
        d.mkdir(exist_ok=True)
        sky = run(skycmd, env)
        (d / "sky.rad").write_text(sky + glow_lines())
        oct_full, oct_black, oct_sky = d / "scene.oct", d / "black.oct", d / "sky.oct"
        for o, files in ((oct_full, ["sky.rad", "../scene.rad"]),
                         (oct_black, ["sky.rad", "../scene_black.rad"]),
                         (oct_sky, ["sky.rad"])):
            o.write_bytes(subprocess.run(["oconv", "-f"] + files, env=env, cwd=d,
                                         capture_output=True, check=True).stdout)
        print(f"## {title}")
        print()
        print("sky: `" + " ".join(skycmd) + "`")
        sun_line = [l for l in sky.splitlines() if "Solar altitude" in l]

        # Unobstructed horizontal illuminance of the Radiance sky (no scene): sun, sky.
        up_pt = "0 0 0 0 0 1\n"
        e_sun = rtrace(oct_sky, up_pt, "-ab 0", env, 1)[0][0]
        e_all = rtrace(oct_sky, up_pt, "-ab 1 -aa 0 -ad 262144 -lw 1e-8", env, a.nproc)[0][0]

        # daystep at each quality, cold.
        ds = {}
        for q in qualities:
            rows, secs, report, cmd = daystep_instant(exe, scene_path, dsargs, d / f"daystep-{q}",
                                                     q, env, threads=a.nproc)
            ds[q] = (rows, secs, report, cmd)
        rep = ds["default"][2]
        if sun_line:
            s = rep["sun"]
            print(f"sun: Radiance {sun_line[0].split(':', 1)[1].strip()} (altitude, azimuth from "
                  f"south, west +); daystep altitude {s['altitude_deg']:.2f}°, azimuth "
                  f"{s['azimuth_deg'] - 180.0:+.2f}° from south (with refraction)")
        open_rows = daystep_open_sky(exe, work, site, rho_g, dsargs, env, a.nproc)
        if len(rows) != len(sensors):
            sys.exit(f"daystep gave {len(rows)} sensors, the .pts has {len(sensors)}")
        print(f"sky alone, unobstructed horizontal sensor: Radiance sun {e_sun:.0f} lx, sky "
              f"{e_all - e_sun:.0f} lx; daystep sun {open_rows['lux_sun']:.0f} lx, sky "
              f"{open_rows['lux_sky']:.0f} lx ({100 * (open_rows['lux_sky'] / (e_all - e_sun) - 1):+.1f} %)")
        print()

        # Radiance runs.
        ref, t_ref, cmd_ref = rtrace(oct_full, pts_text, ref_opts, env, a.nproc)
        half, t_half, _ = rtrace(oct_full, pts_text, half_opts, env, a.nproc)
        # Noise of the reference from the two runs: var(half - ref) = σ²_half + σ²_ref
        # = 3 σ²_ref for σ ∝ 1/√samples.
        pair = [(h - r) / r for h, r in zip(half, ref) if r > LUX_MIN]
        ref_noise = math.sqrt(sum(x * x for x in pair) / len(pair) / 3.0)
        sun_only, t_sun, cmd_sun = rtrace(oct_black, pts_text, DIRECT_SUN, env, a.nproc)
        direct, t_dir, cmd_dir = rtrace(oct_black, pts_text, DIRECT_SKY, env, a.nproc)
        others = [(label, *rtrace(oct_full, pts_text, o, env, a.nproc)) for label, o in RADIANCE_ROWS]

        print("| tool / settings | wall s | mean \\|rel. diff.\\| | mean rel. diff. (bias) | RMS "
              "| max | daystep's stated error (median lux_err/lux) | within lux_err |")
        print("|---|---|---|---|---|---|---|---|")
        def short(opts):
            o = opts.split()
            return " ".join(f"{k} {o[o.index(k) + 1]}" for k in ("-ab", "-ad") if k in o)
        ref_label = f"Radiance reference ({'quick, ' if a.quick else ''}{short(ref_opts)}, -aa 0 -as 0)"
        print(f"| {ref_label} | {t_ref:.0f} | — | — | ≈{100 * ref_noise:.2f} % noise (est.) "
              "| — | — | — |")
        print(fmt_row(f"Radiance, half the samples ({short(half_opts)}): noise check", t_half,
                      compare(half, ref)))
        for label, vals, secs, _ in others:
            print(fmt_row(label, secs, compare(vals, ref)))
        for q in qualities:
            rows, secs, report, _ = ds[q]
            vals = [r["lux"] for r in rows]
            errs = [r["lux_err"] for r in rows]
            c = compare(vals, ref, errs, ref_noise)
            print(fmt_row(f"daystep --quality {q} (cold)", secs, c))
        n_used = sum(1 for r in ref if r > LUX_MIN)
        print()
        print(f"{n_used} of {len(ref)} sensors above {LUX_MIN:g} lx in the reference; "
              f"reference mean {statistics.mean(ref):.0f} lx, min {min(ref):.0f}, "
              f"max {max(ref):.0f}. \"within lux_err\": |daystep − reference| ≤ lux_err + 2σ of "
              "the reference's noise.")
        print()
        # Components: sun, sky (+ ground glow) directly, interreflected.
        ref_sky = [t - s for t, s in zip(direct, sun_only)]
        ref_ind = [t - dr for t, dr in zip(ref, direct)]
        summary(ds, ref, ref_ind, groups, ref_noise)

        # Every sensor's values, for a closer look (and the depth profile below).
        cols = ["ref", "ref_half", "ref_sun", "ref_sky", "ref_indirect"] + [
            "radiance_ab5", "radiance_ab2"] + [f"{q}_{c}" for q in qualities for c in (
                "lux", "lux_err", "lux_sun", "lux_sky", "lux_indirect")]
        with open(d / "compare.csv", "w") as f:
            f.write("sensor,x,y,z," + ",".join(cols) + ",group\n")
            for k, (model_p, _, _) in enumerate(sensors):
                vals = [ref[k], half[k], sun_only[k], ref_sky[k], ref_ind[k]] + [
                    o[1][k] for o in others] + [ds[q][0][k][c] for q in qualities for c in (
                        "lux", "lux_err", "lux_sun", "lux_sky", "lux_indirect")]
                f.write(f"{k},{model_p[0]:g},{model_p[1]:g},{model_p[2]:g}," +
                        ",".join(f"{v:.3f}" for v in vals) + f",{groups[k] or ''}\n")
        print("Parts (means over the sensors above 10 lx; Radiance's from direct-only runs with "
              "every opaque surface black):")
        print()
        print("| part | Radiance lux | daystep draft | daystep default | daystep high | "
              "RMS rel. diff. (high) |")
        print("|---|---|---|---|---|---|")
        idx = [k for k, r in enumerate(ref) if r > LUX_MIN]
        for part, rv, col in (("sun", sun_only, "lux_sun"), ("sky + ground glow", ref_sky, "lux_sky"),
                              ("interreflected", ref_ind, "lux_indirect"), ("total", ref, "lux")):
            rmean = statistics.mean(rv[k] for k in idx)
            cells = []
            for q in qualities:
                dm = statistics.mean(ds[q][0][k][col] for k in idx)
                cells.append(f"{dm:.0f} ({100 * (dm - rmean) / rmean:+.1f} %)" if rmean > 0 else f"{dm:.0f}")
            hv = [ds["high"][0][k][col] for k in idx]
            sel = [(h, rv[k]) for h, k in zip(hv, idx) if rv[k] > LUX_MIN]
            rms = (100 * math.sqrt(sum(((h - r) / r) ** 2 for h, r in sel) / len(sel))
                   if sel else float("nan"))
            print(f"| {part} | {rmean:.0f} | " + " | ".join(cells) + f" | {rms:.1f} % |")
        print()
        # Depth profile: rows of sensors by distance from the first wall in .pts order
        # (for the office: y, metres from the south window wall).
        ys = sorted({round(p[1], 6) for p, _, _ in sensors})
        if 2 < len(ys) <= 40 and not any(groups):
            print("By sensor row (model y; means over the row): interreflected lux and "
                  "daystep − reference for the total, relative:")
            print()
            print("| y | reference lux | ref. interreflected | daystep high interreflected | "
                  "total: draft | default | high |")
            print("|---|---|---|---|---|---|---|")
            for y in ys:
                ks = [k for k, (p, _, _) in enumerate(sensors) if round(p[1], 6) == y]
                rm = statistics.mean(ref[k] for k in ks)
                im = statistics.mean(ref_ind[k] for k in ks)
                dm = statistics.mean(ds["high"][0][k]["lux_indirect"] for k in ks)
                rel = [100 * statistics.mean((ds[q][0][k]["lux"] - ref[k]) / ref[k] for k in ks)
                       for q in qualities]
                print(f"| {y:g} | {rm:.0f} | {im:.0f} | {dm:.0f} ({100 * (dm - im) / im:+.1f} %) | "
                      + " | ".join(f"{r:+.1f} %" for r in rel) + " |")
            print()
        print("Radiance command lines:")
        print()
        print(f"- reference: `{cmd_ref}`")
        print(f"- sun only (black scene): `{cmd_sun}`; sun + sky (black scene): `{cmd_dir}`")
        for (label, o) in RADIANCE_ROWS:
            print(f"- {label}: `rtrace -I -h -w -n {a.nproc} {two_sided(o)}`")
        print(f"- daystep: `{' '.join(map(str, ds['default'][3]))}` (and draft, high)")
        print()
    if a.annual:
        annual_study(a, env, exe, scene_path, work, pts_text, rho_g)
    print("load average at the end (1, 5, 15 min): "
          + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
