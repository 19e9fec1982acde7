"""What a schema cannot check in docs/examples/cluster/*.yaml (issue 27).

Run by tests/cluster/k8s-check.sh after kubernetes-validate, with the venv's Python (PyYAML):

- the Indexed Job: completions = SHARDS, parallelism <= completions, THREADS = the CPU request;
- the merge Job: the same STUDY and SHARDS;
- volumes: every volumeMount names a volume of its pod, every claim is the PVC of
  k8s-shared-pvc.yaml (ReadWriteMany), both Jobs mount it at the same path;
- the commands: each container's shell script, run with a stub `daystep` that prints its
  arguments, calls daystep exactly as the Slurm scripts do with ROOT=/shared (every
  completion index against its array task, and the merge), and the commands in
  docs/cluster.md name these Jobs; with DAYSTEP (a binary), every flag they use exists.
"""

import os
import re
import subprocess
import sys
import tempfile

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
EX = os.path.join(REPO, "docs", "examples", "cluster")
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
    return ok


def load(name):
    with open(os.path.join(EX, name)) as f:
        docs = [d for d in yaml.safe_load_all(f) if d]
    check(len(docs) == 1, f"{name}: one resource, not {len(docs)}")
    return docs[0]


def env_of(container):
    return {e["name"]: str(e["value"]) for e in container.get("env", []) if "value" in e}


def run_with_stub(argv, env, cwd):
    """Runs argv with a `daystep` on PATH that prints its arguments, one a line."""
    stubdir = os.path.join(cwd, "bin")
    os.makedirs(stubdir, exist_ok=True)
    stub = os.path.join(stubdir, "daystep")
    with open(stub, "w") as f:
        f.write('#!/bin/sh\nfor a in "$@"; do printf "%s\\n" "$a"; done\n')
    os.chmod(stub, 0o755)
    full = {"PATH": stubdir + os.pathsep + "/usr/bin:/bin", "HOME": cwd}
    full.update(env)
    r = subprocess.run(argv, env=full, cwd=cwd, capture_output=True, text=True)
    check(r.returncode == 0, f"{argv[:2]} with {env}: exit {r.returncode}: {r.stderr.strip()}")
    return r.stdout.splitlines()


pvc = load("k8s-shared-pvc.yaml")
annual = load("k8s-annual-indexed-job.yaml")
merge = load("k8s-merge-job.yaml")

check(pvc["kind"] == "PersistentVolumeClaim", "k8s-shared-pvc.yaml: not a PersistentVolumeClaim")
check("ReadWriteMany" in pvc["spec"]["accessModes"], "the shared PVC is not ReadWriteMany")
claim = pvc["metadata"]["name"]

mounts = {}
for name, job in (("k8s-annual-indexed-job.yaml", annual), ("k8s-merge-job.yaml", merge)):
    check(job["kind"] == "Job", f"{name}: not a Job")
    pod = job["spec"]["template"]["spec"]
    check(pod.get("restartPolicy") == "Never", f"{name}: restartPolicy is not Never")
    volumes = {v["name"]: v for v in pod.get("volumes", [])}
    for c in pod["containers"]:
        for m in c.get("volumeMounts", []):
            check(m["name"] in volumes, f"{name}: mount {m['name']!r} names no volume of the pod ({sorted(volumes)})")
            mounts.setdefault(name, set()).add(m["mountPath"])
    for v in volumes.values():
        got = v.get("persistentVolumeClaim", {}).get("claimName")
        check(got == claim, f"{name}: volume {v['name']!r} claims {got!r}, not the shared PVC {claim!r}")
    check(len(pod["containers"]) == 1, f"{name}: one container")
check(
    mounts.get("k8s-annual-indexed-job.yaml") == mounts.get("k8s-merge-job.yaml") == {"/shared"},
    f"the Jobs mount the shared volume at different paths: {mounts}",
)

spec = annual["spec"]
ca = annual["spec"]["template"]["spec"]["containers"][0]
cm = merge["spec"]["template"]["spec"]["containers"][0]
ea, em = env_of(ca), env_of(cm)
shards = int(ea["SHARDS"])
check(spec.get("completionMode") == "Indexed", "the annual Job is not an Indexed Job")
check(spec["completions"] == shards, f"completions {spec['completions']} != SHARDS {shards}")
check(1 <= spec.get("parallelism", 1) <= spec["completions"], "parallelism is not within 1..completions")
check(ea["THREADS"] == str(ca["resources"]["requests"]["cpu"]), "THREADS differs from the CPU request")
check(em["SHARDS"] == ea["SHARDS"], f"the merge's SHARDS {em['SHARDS']} != the annual Job's {ea['SHARDS']}")
check(em["STUDY"] == ea["STUDY"], "the merge's STUDY differs from the annual Job's")
check(merge["metadata"]["labels"]["study"] == annual["metadata"]["labels"]["study"] == ea["STUDY"], "study labels")

# The commands, against the Slurm scripts with ROOT=/shared (the layout both use).
with tempfile.TemporaryDirectory() as tmp:
    for i in range(shards):
        env = dict(ea, JOB_COMPLETION_INDEX=str(i))
        k8s = run_with_stub(ca["command"] + ca["args"], env, tmp)
        slurm_env = {
            "ROOT": "/shared",
            "SCENE": ea["SCENE"],
            "WEATHER": ea["WEATHER"],
            "STUDY": ea["STUDY"],
            "QUALITY": ea["QUALITY"],
            "SHARDS": ea["SHARDS"],
            "SLURM_ARRAY_TASK_ID": str(i + 1),
            "SLURM_CPUS_PER_TASK": ea["THREADS"],
        }
        slurm = run_with_stub(["bash", os.path.join(EX, "slurm-annual.sbatch")], slurm_env, tmp)
        check(k8s == slurm, f"completion index {i}: daystep {' '.join(k8s)} != Slurm task {i + 1}: daystep {' '.join(slurm)}")
        check(f"--shard {i + 1}/{shards}" in " ".join(k8s), f"completion index {i} does not run --shard {i + 1}/{shards}")
    k8s_merge = run_with_stub(cm["command"] + cm["args"], em, tmp)
    slurm_merge = run_with_stub(
        ["bash", os.path.join(EX, "slurm-merge.sbatch")],
        {"ROOT": "/shared", "STUDY": em["STUDY"], "SHARDS": em["SHARDS"], "STEP": em["STEP"]},
        tmp,
    )
    check(k8s_merge == slurm_merge, f"merge: daystep {' '.join(k8s_merge)} != Slurm's daystep {' '.join(slurm_merge)}")
    folders = [f"/shared/runs/{em['STUDY']}/shard-{k}" for k in range(1, shards + 1)]
    check(k8s_merge[: shards + 1] == ["merge"] + folders, f"the merge does not name all {shards} shard folders in order")
    check(
        k8s_merge[shards + 1 :] == ["--out", f"/shared/runs/{em['STUDY']}/merged", "--step", em["STEP"]],
        f"the merge's flags: {k8s_merge[shards + 1:]}",
    )
    print(f"k8s-check: daystep {' '.join(k8s)}")
    print(f"k8s-check: daystep {' '.join(k8s_merge)}")

# docs/cluster.md: the study split commands and the kubectl steps name these files and Jobs.
with open(os.path.join(REPO, "docs", "cluster.md")) as f:
    md = f.read()
check(
    "daystep merge runs/STUDY/shard-1 … runs/STUDY/shard-N --out runs/STUDY/merged" in md,
    "docs/cluster.md no longer gives the merge as `daystep merge runs/STUDY/shard-1 … --out runs/STUDY/merged`",
)
check(f"job/{annual['metadata']['name']}" in md, f"docs/cluster.md does not wait for job/{annual['metadata']['name']}")
for name in ("k8s-shared-pvc.yaml", "k8s-annual-indexed-job.yaml", "k8s-merge-job.yaml"):
    check(f"kubectl apply -f {name}" in md, f"docs/cluster.md does not apply {name}")

# Every flag the Jobs pass exists in the binary's help.
daystep = os.environ.get("DAYSTEP")
if daystep:
    for sub, argv in (("annual", k8s), ("merge", k8s_merge)):
        helptext = subprocess.run([daystep, sub, "--help"], capture_output=True, text=True, check=True).stdout
        top = subprocess.run([daystep, "--help"], capture_output=True, text=True, check=True).stdout
        for flag in (a for a in argv if a.startswith("--")):
            check(re.search(rf"(?m)^\s+(-\w, )?{re.escape(flag)}\b", helptext + top) is not None, f"daystep {sub}: no flag {flag}")
else:
    print("k8s-check: DAYSTEP not set, the flags were not checked against the binary")

for f in failures:
    print(f"k8s-check: FAILED: {f}", file=sys.stderr)
if failures:
    sys.exit(1)
print(f"k8s-check: {shards} completions = SHARDS, volumes and claim agree, commands = the Slurm scripts'")
