"""Peer bench: daystep's LEED v4.1 Option 1 and EN 17037 code against
honeybee-radiance-postprocess on the same random-but-seeded hourly matrices.

    python peer.py make DIR       # writes the cases in honeybee's results layout
    python peer.py honeybee DIR   # runs honeybee-radiance-postprocess on each case
    python peer.py compare DIR    # compares DIR/<case>/honeybee.json with daystep.json

daystep's side is `cargo bench --bench postprocess_peer -- DIR` (tests/bench/postprocess_peer.rs),
run by run.sh between `honeybee` and `compare`. Not part of `cargo test`.
"""
import json
import sys
from pathlib import Path

import numpy as np

# (name, seed, grids: [(sensors, groups, with_static)])
CASES = [
    ("one_group", 1, [(60, 1, False)]),
    ("three_groups_static", 2, [(80, 3, True)]),
    ("two_grids_shared_group", 3, [(50, 2, True), (70, 2, False)]),
    ("five_groups", 4, [(40, 5, True)]),
    ("seven_groups_descending", 5, [(60, 7, False)]),
    # sensor areas from a model's grid meshes (cells 0.1 to 1 m wide): area weighting
    ("area_weighted", 6, [(30, 2, True), (45, 3, False)]),
]
SUN_UP = [d * 24 + h for d in range(365) for h in range(6, 20)]  # 14 sun-up hours a day


def make_case(root: Path, name: str, seed: int, grids):
    rng = np.random.default_rng(seed)
    folder = root / name / "results"
    folder.mkdir(parents=True, exist_ok=True)
    n_hours = len(SUN_UP)
    (folder / "sun-up-hours.txt").write_text("\n".join(f"{h + 0.5}" for h in SUN_UP) + "\n")
    study = {"timestep": 1, "study_hours": [h + 0.5 for h in range(8760)]}
    (folder / "study_info.json").write_text(json.dumps(study))
    grids_info, grid_states = [], {}
    shared = None
    for gi, (sensors, groups, static) in enumerate(grids):
        gid = f"grid_{gi}"
        names = [f"{gid}_g{k}" for k in range(groups)]
        if name == "two_grids_shared_group":
            # the second grid sees the first grid's first group too
            shared = shared or names[0]
            names[0] = shared
        lps = ([["__static_apertures__"]] if static else []) + [[n] for n in names]
        grids_info.append({"count": sensors, "name": gid, "identifier": gid,
                           "full_id": gid, "group": "", "light_path": lps})
        grid_states[gid] = {n: [f"0_{n}"] for n in names}
        # sensors from the window inwards: light falls off with depth
        depth = np.exp(-3.0 * np.arange(sensors) / sensors)[:, None]
        for lp in lps:
            lp = lp[0]
            is_static = lp == "__static_apertures__"
            state = "default" if is_static else f"0_{lp}"
            # direct sun through this path: near-window sensors lit more often; static
            # apertures (a skylight, say) rarely, so that a few hours cannot comply
            p_lit = (0.004 if is_static else rng.uniform(0.01, 0.05)) * depth
            lit = rng.random((sensors, n_hours)) < p_lit
            direct = np.where(lit, rng.uniform(500, 3000, (sensors, n_hours)), 0.0)
            # a few exact threshold values, to test >= and > on purpose
            direct[rng.random((sensors, n_hours)) < 0.002] = 1000.0
            diffuse = rng.gamma(2.0, 700.0 * depth / len(lps), (sensors, n_hours))
            total = direct + diffuse
            total[rng.random((sensors, n_hours)) < 0.002] = 300.0
            for res, arr in (("direct", direct), ("total", total)):
                p = folder / lp / state / res
                p.mkdir(parents=True, exist_ok=True)
                np.save(p / f"{gid}.npy", arr.astype(np.float32))
    (folder / "grids_info.json").write_text(json.dumps(grids_info, indent=2))
    (folder / "grid_states.json").write_text(json.dumps(grid_states, indent=2))
    if name == "area_weighted":
        write_model(root / name, rng, grids_info)
    # EN 17037 daylight hours: 4380 hours, a seeded random half of the year's hours
    hours = rng.permutation(8760)[:4380]
    sched = np.zeros(8760, dtype=int)
    sched[hours] = 1
    (root / name / "daylight_hours.csv").write_text("\n".join(map(str, sched)) + "\n")


def write_model(case: Path, rng, grids_info):
    """A honeybee model beside results/ whose sensor grids are meshes of one quad per
    sensor, of random widths: honeybee's LEED weights by their face areas. The same areas
    go to areas.json for daystep."""
    from honeybee.model import Model
    from honeybee_radiance.sensorgrid import SensorGrid
    from ladybug_geometry.geometry3d import Mesh3D, Point3D

    grids, areas = [], {}
    for g in grids_info:
        widths = rng.uniform(0.1, 1.0, g["count"])
        x = np.concatenate([[0.0], np.cumsum(widths)])
        verts = [Point3D(float(xi), y, 0.0) for xi in x for y in (0.0, 1.0)]
        faces = [(2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1) for i in range(g["count"])]
        grid = SensorGrid.from_mesh3d(g["full_id"], Mesh3D(verts, faces))
        grids.append(grid)
        areas[g["full_id"]] = [float(a) for a in grid.mesh.face_areas]
    model = Model("peer_model")
    model.properties.radiance.sensor_grids = grids
    model.to_hbjson("model", folder=str(case))
    (case / "areas.json").write_text(json.dumps(areas))


def run_honeybee(root: Path):
    from honeybee_radiance_postprocess.leed.leed import leed_option_one
    from honeybee_radiance_postprocess.en17037 import en17037_compute
    from honeybee_radiance_postprocess.results.annual_daylight import AnnualDaylight
    from honeybee_radiance_postprocess.util import filter_array

    from importlib.metadata import version as _version
    version = _version("honeybee-radiance-postprocess")
    import honeybee_radiance_postprocess.leed.leed_schedule as leed_schedule

    class StableArgsort:
        """numpy with a stable argsort, for the worst-offender ranking: numpy's default
        argsort is not stable (SIMD sorts on AVX-512), so ties between groups rank in an
        order no other program can reproduce; daystep ranks ties in path order."""

        def __getattr__(self, k):
            return getattr(np, k)

        def argsort(self, a, axis=-1, **_):
            return np.argsort(a, axis=axis, kind="stable")

    def leed(folder):
        (summary, summary_grid, da_grids, hours_above, states_schedule, fail_to_comply,
         grids_info) = leed_option_one(str(folder), shade_transmittance=0.05)
        return {
            "sda": summary["sda"], "ase": summary["ase"], "credits": summary["credits"],
            "grids": [{"name": g["name"],
                       "sda": summary_grid[g["full_id"]]["sda"],
                       "sda_blinds_up": summary_grid[g["full_id"]]["sda_blinds_up"],
                       "sda_blinds_down": summary_grid[g["full_id"]]["sda_blinds_down"],
                       "ase": summary_grid[g["full_id"]]["ase"],
                       "da": [float(x) for x in da],
                       "hours_above": [int(x) for x in ha],
                       "fail_hoys": fail_to_comply.get(g["name"], [])}
                      for g, da, ha in zip(grids_info, da_grids, hours_above)],
            # 8760 values per group: 0 open, 1 shaded; keep the sun-up hours
            "schedule": {k: [int(v["values"][h]) for h in SUN_UP]
                         for k, v in states_schedule.items()},
        }

    for name, _, _ in CASES:
        folder = root / name / "results"
        out = {"leed": leed(folder)}
        leed_schedule.np = StableArgsort()
        out["leed_stable_argsort"] = leed(folder)
        leed_schedule.np = np
        sched = [int(x) for x in (root / name / "daylight_hours.csv").read_text().split()]
        results = AnnualDaylight(str(folder), schedule=sched)
        en = []
        for g in results.grids_info:
            array = results._array_from_states(g, states=None, res_type="total",
                                               zero_array=True)
            if np.any(array):
                array = np.apply_along_axis(filter_array, 1, array, results.occ_mask)
            area_file = root / name / "areas.json"
            area = (np.array(json.loads(area_file.read_text())[g["full_id"]])
                    if area_file.exists() else None)
            r = en17037_compute(array, g, area_array=area)
            levels = {}
            for tt, key in (("Target Illuminance", "target"), ("Minimum Illuminance", "minimum")):
                for level, d in r["target_types"][tt]["levels"].items():
                    levels.setdefault(level, {})[f"{key}_area_pct"] = d["sda"]
                    levels[level][f"{key}_pass"] = bool(d["passes"])
            en.append({"name": g["name"], **levels})
        out["en17037"] = {"grids": en}
        out["version"] = version
        (root / name / "honeybee.json").write_text(json.dumps(out))
        print(f"{name}: honeybee done", file=sys.stderr)


def compare_leed(name, hl, ds, check, diffs):
    """Compares one honeybee LEED block with daystep's; returns (group-hours, sensors)."""
    dl = ds["leed"]
    # honeybee rounds its summaries to 2 decimals; daystep keeps them whole
    check(name, "sDA", hl["sda"], round(dl["sda_pct"], 2))
    check(name, "ASE", hl["ase"], round(dl["ase_pct"], 2))
    credits = hl["credits"]
    want = (3, True) if credits == "Exemplary performance" else (credits, False)
    check(name, "points", want, (dl["points"], dl["exemplary_performance"]))
    sensors = hours = 0
    for hg, dg in zip(hl["grids"], dl["grids"]):
        g = f"{name}/{hg['name']}"
        for k, dk in (("sda", "sda_pct"), ("sda_blinds_up", "sda_blinds_open_pct"),
                      ("sda_blinds_down", "sda_blinds_shaded_pct"), ("ase", "ase_pct")):
            check(g, k, hg[k], round(dg[dk], 2))
        for i, (a, b) in enumerate(zip(hg["da"], dg["da"])):
            check(g, f"DA sensor {i}", a, b, 1e-9)
        for i, (a, b) in enumerate(zip(hg["hours_above"], dg["ase_hours"])):
            check(g, f"ASE hours sensor {i}", a, b)
        check(g, "hours that cannot comply", hg["fail_hoys"], dg["fail_hoys"])
        sensors += len(hg["da"])
    for grp, vals in hl["schedule"].items():
        dv = ds["schedule"].get(grp)
        if dv is None:
            diffs.append(f"{name}: group {grp} missing from daystep's schedule")
            continue
        bad = [i for i, (a, b) in enumerate(zip(vals, dv)) if a != b]
        hours += len(vals)
        if bad:
            diffs.append(f"{name}: schedule of {grp} differs at {len(bad)} sun-up hours "
                         f"(first {SUN_UP[bad[0]]})")
    return hours, sensors


def compare(root: Path):
    rows, diffs, all_stable = [], [], []

    def check(case, what, a, b, tol=0.0):
        same = a == b if tol == 0 else abs(a - b) <= tol
        if not same:
            diffs.append(f"{case}: {what}: honeybee {a!r} daystep {b!r}")
        return same

    for name, _, _ in CASES:
        hb = json.loads((root / name / "honeybee.json").read_text())
        ds = json.loads((root / name / "daystep.json").read_text())
        n0 = len(diffs)
        hours, sensors = compare_leed(name, hb["leed"], ds, check, diffs)
        leed_ok = len(diffs) == n0
        stable_diffs = []

        def check_stable(case, what, a, b, tol=0.0):
            same = a == b if tol == 0 else abs(a - b) <= tol
            if not same:
                stable_diffs.append(f"{case}: {what}: honeybee {a!r} daystep {b!r}")
            return same

        compare_leed(name, hb["leed_stable_argsort"], ds, check_stable, stable_diffs)
        all_stable.extend(stable_diffs)
        n1 = len(diffs)
        for hg, dg in zip(hb["en17037"]["grids"], ds["en17037"]["grids"]):
            for level in ("minimum", "medium", "high"):
                for k in ("target_area_pct", "target_pass", "minimum_area_pct", "minimum_pass"):
                    check(f"{name}/{hg['name']}", f"EN 17037 {level}.{k}",
                          hg[level][k], dg[level][k], 1e-9 if k.endswith("pct") else 0)
        hl = hb["leed"]
        rows.append((name, len(hl["grids"]), sensors, hours, hl["sda"], hl["ase"],
                     hl["credits"], leed_ok, len(diffs) == n1, not stable_diffs))
    print(f"honeybee-radiance-postprocess {hb.get('version')}")
    yes = lambda b: "yes" if b else "NO"  # noqa: E731
    print("| case | grids | sensors | group-hours | sDA % | ASE % | points | LEED agrees "
          "| EN 17037 agrees | LEED, stable argsort |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print("| " + " | ".join(str(x) for x in r[:-3]) + " | "
              + " | ".join(yes(b) for b in r[-3:]) + " |")
    if diffs:
        print(f"\n{len(diffs)} differences (honeybee as installed):")
        for d in diffs:
            print("-", d)
    if all_stable:
        print(f"\n{len(all_stable)} differences (honeybee with a stable argsort):")
        for d in all_stable:
            print("-", d)
    return 0 if not all_stable else 1


if __name__ == "__main__":
    cmd, root = sys.argv[1], Path(sys.argv[2])
    if cmd == "make":
        for c in CASES:
            make_case(root, *c)
    elif cmd == "honeybee":
        run_honeybee(root)
    elif cmd == "compare":
        sys.exit(compare(root))
