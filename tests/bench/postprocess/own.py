"""daystep's own `annual --leed --en17037` output fed to honeybee-radiance-postprocess:
the light paths' hourly totals and direct-sun values, written in honeybee's results
layout, and honeybee's LEED v4.1 Option 1 and EN 17037 compared with what daystep wrote
(leed.json, leed_sensors.csv, leed_blinds.csv, en17037.json).

    python own.py ANNUAL_DIR EPW CASE_DIR

Run by run-own.sh (which installs the package). Two cases under CASE_DIR:
  paths/  every light path of the run (static first, then the groups), as daystep's LEED
          saw them: LEED is compared;
  main/   the run's own totals (every group open) as one static path: EN 17037 is
          compared (daystep's EN 17037 reads the run's totals, not the paths' sum).
The EN 17037 daylight hours are ladybug's: the 4380 largest diffuse horizontal
illuminances of the EPW (`highest_values`), as honeybee-radiance's epw-to-daylight-hours.
"""
import csv
import json
import sys
from pathlib import Path

import numpy as np

STATIC = "__static_apertures__"


def read_csv(path: Path):
    with open(path) as f:
        r = csv.reader(f)
        next(r)
        rows = list(r)
    return [row[0] for row in rows], np.array([[float(x) for x in row[1:]] for row in rows])


def write_case(folder: Path, paths, sun_up, n_sensors):
    """paths: [(name, total, direct)] with arrays steps × sensors (daystep's layout)."""
    res = folder / "results"
    res.mkdir(parents=True, exist_ok=True)
    (res / "sun-up-hours.txt").write_text("\n".join(f"{h + 0.5}" for h in sun_up) + "\n")
    study = {"timestep": 1, "study_hours": [h + 0.5 for h in range(8760)]}
    (res / "study_info.json").write_text(json.dumps(study))
    gid = "sensors"
    groups = [p[0] for p in paths if p[0] != STATIC]
    lps = [[p[0]] for p in paths]
    info = [{"count": n_sensors, "name": gid, "identifier": gid, "full_id": gid,
             "group": "", "light_path": lps}]
    (res / "grids_info.json").write_text(json.dumps(info, indent=2))
    (res / "grid_states.json").write_text(json.dumps({gid: {g: [f"0_{g}"] for g in groups}}))
    for name, total, direct in paths:
        state = "default" if name == STATIC else f"0_{name}"
        for kind, arr in (("total", total), ("direct", direct)):
            p = res / name / state / kind
            p.mkdir(parents=True, exist_ok=True)
            # honeybee's layout: sensors × sun-up hours, float32
            np.save(p / f"{gid}.npy", arr[sun_up, :].T.astype(np.float32))


def make(annual: Path, epw: Path, case: Path):
    leed = json.loads((annual / "leed.json").read_text())
    report = json.loads((annual / "report.json").read_text())
    from_run = set(report["compliance"]["paths_from_run"])
    times, main = read_csv(annual / "illuminance.csv")
    _, main_sun = read_csv(annual / "direct_sun.csv")
    assert len(times) == 8760, "a whole hourly year"
    paths = []
    for lp in leed["light_paths"]:
        name = lp["name"]
        assert lp["shade_transmittance"] in (None, 0.05), "honeybee's side uses 0.05"
        d = annual if name in from_run else annual / "paths" / name
        paths.append((name, read_csv(d / "illuminance.csv")[1],
                      read_csv(d / "direct_sun.csv")[1]))
    # Steps with any light: the others change no LEED or EN 17037 number.
    lit = np.zeros(8760, dtype=bool)
    for _, t, dsun in paths + [("main", main, main_sun)]:
        lit |= (t > 0).any(axis=1) | (dsun > 0).any(axis=1)
    sun_up = [int(h) for h in np.nonzero(lit)[0]]
    n = main.shape[1]
    write_case(case / "paths", paths, sun_up, n)
    write_case(case / "main", [(STATIC, main, main_sun)], sun_up, n)
    (case / "times.json").write_text(json.dumps({"times": times, "sun_up": sun_up}))

    from ladybug.epw import EPW
    _, idx = EPW(str(epw)).diffuse_horizontal_illuminance.highest_values(4380)
    sched = np.zeros(8760, dtype=int)
    sched[list(idx)] = 1
    (case / "daylight_hours.csv").write_text("\n".join(map(str, sched)) + "\n")


def compare(annual: Path, case: Path):
    from honeybee_radiance_postprocess.leed.leed import leed_option_one
    from honeybee_radiance_postprocess.en17037 import en17037_compute
    from honeybee_radiance_postprocess.results.annual_daylight import AnnualDaylight
    from honeybee_radiance_postprocess.util import filter_array
    from importlib.metadata import version

    diffs = []

    def check(what, a, b, tol=0.0):
        if not (a == b if tol == 0 else abs(a - b) <= tol):
            diffs.append(f"{what}: honeybee {a!r} daystep {b!r}")

    times = json.loads((case / "times.json").read_text())["times"]
    (summary, grid_summary, da_grids, hours_above, states, fail, info) = leed_option_one(
        str(case / "paths" / "results"), shade_transmittance=0.05)
    ours = json.loads((annual / "leed.json").read_text())
    check("sDA %", summary["sda"], round(ours["sda_pct"], 2))
    check("ASE %", summary["ase"], round(ours["ase_pct"], 2))
    credits = summary["credits"]
    want = (3, True) if credits == "Exemplary performance" else (credits, False)
    check("points", want, (ours["points"], ours["exemplary_performance"]))
    g = ours["grids"][0]
    hg = grid_summary["sensors"]
    for k, dk in (("sda", "sda_pct"), ("sda_blinds_up", "sda_blinds_open_pct"),
                  ("sda_blinds_down", "sda_blinds_shaded_pct"), ("ase", "ase_pct")):
        check(f"grid {k}", hg[k], round(g[dk], 2))
    with open(annual / "leed_sensors.csv") as f:
        rows = list(csv.DictReader(f))
    for i, (a, b, r) in enumerate(zip(da_grids[0], hours_above[0], rows)):
        check(f"DA sensor {i}", float(a), float(r["da_pct"]), 1e-9)
        check(f"ASE hours sensor {i}", int(b), round(float(r["ase_hours"])))
    check("hours that cannot comply", len(fail.get("sensors", [])), g["hours_fail_to_comply"])
    # The blind schedule: daystep's rows (occupied sun-up steps) against honeybee's 8760.
    with open(annual / "leed_blinds.csv") as f:
        blinds = list(csv.reader(f))
    hoy = {t: i for i, t in enumerate(times)}
    shaded_hours = 0
    for row in blinds[1:]:
        h = hoy[row[0]]
        for gname, v in zip(blinds[0][1:], row[1:]):
            check(f"blind {gname} at {row[0]}", int(states[gname]["values"][h]), int(v))
            shaded_hours += int(v)
    # EN 17037 on the run's totals.
    sched = [int(x) for x in (case / "daylight_hours.csv").read_text().split()]
    results = AnnualDaylight(str(case / "main" / "results"), schedule=sched)
    en = json.loads((annual / "en17037.json").read_text())["grids"][0]
    for gi in results.grids_info:
        array = results._array_from_states(gi, states=None, res_type="total", zero_array=True)
        if np.any(array):
            array = np.apply_along_axis(filter_array, 1, array, results.occ_mask)
        r = en17037_compute(array, gi)
        for tt, key in (("Target Illuminance", "target"), ("Minimum Illuminance", "minimum")):
            for level, d in r["target_types"][tt]["levels"].items():
                check(f"EN 17037 {level}.{key}_area_pct", d["sda"], en[level][f"{key}_area_pct"],
                      1e-9)
                check(f"EN 17037 {level}.{key}_pass", bool(d["passes"]), en[level][f"{key}_pass"])
    print(f"honeybee-radiance-postprocess {version('honeybee-radiance-postprocess')}")
    print("| what | honeybee | daystep |")
    print("|---|---|---|")
    print(f"| light paths | {len(info[0]['light_path'])} | {len(ours['light_paths'])} |")
    print(f"| sDA300/50% with blinds, % | {summary['sda']} | {round(ours['sda_pct'], 2)} |")
    print(f"| ASE1000,250h, % | {summary['ase']} | {round(ours['ase_pct'], 2)} |")
    print(f"| points | {credits} | {ours['points']} |")
    print(f"| hours that cannot comply | {len(fail.get('sensors', []))} | "
          f"{g['hours_fail_to_comply']} |")
    print(f"| group-hours shaded (daystep's rows) | | {shaded_hours} |")
    print(f"| sensors compared (DA, ASE hours) | {len(rows)} | {len(rows)} |")
    if diffs:
        print(f"\n{len(diffs)} differences:")
        for d in diffs[:50]:
            print("-", d)
        return 1
    print("\nno differences")
    return 0


if __name__ == "__main__":
    annual, epw, case = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
    make(annual, epw, case)
    sys.exit(compare(annual, case))
