"""Time the bench workloads on a reference commit and on the working tree, in turns: ``python -m benchmarks.against REF``.

REF (a commit, branch or tag) is checked out into a temporary git worktree
(``git worktree add --detach``, removed at the end). Each side runs in its own
processes, with ``PYTHONPATH`` set to that side's ``src`` (the two versions
cannot share a process: their IK modules live in different packages). Each
workload is a Python snippet written for each side's API (:data:`IMPORTS`
holds the import lines of the two layouts; :func:`layout` tells which one a
side has from its files).

1. Check: every workload runs once per side (this also compiles the numba
   kernels, outside any timing: a fresh checkout's kernels are compiled the
   first time, which takes minutes), and the answers of the two sides are
   compared. Poses and Jacobians must agree to 1e-12, closed-form solution
   sets to 1e-9 (the same count per pose, each solution of one side within
   1e-9 of one of the other's), maps exactly; numerical IK must give the same
   joint vectors to 1e-9 and both sides' answers must reach their targets.
   A row that disagrees says WRONG and gets no time.
2. Time, in turns: ``--rounds`` rounds; each round starts one process per side
   per workload, the side that goes first alternating from round to round.
   A process warms every row of its workload up (one untimed call), then
   times it ``--repeats`` times with garbage collection off; the round's
   value is the median of those, per call (or per row of a batch).
3. Cold start: ``tf-between base_link ee_link --robot course_arm`` as a fresh
   process per side, ``--cold-runs`` runs each, interleaved (after one
   untimed run per side, which writes the bytecode), the printed numbers of
   the two sides compared first.

The table gives per row the median over rounds of each side's time, the
ratio new/old of those medians, the smallest and largest per-round ratio, and
a verdict: "slower" when every round's ratio is above 1 + ``NOISE``, "faster"
when every one is below 1 - ``NOISE``, else "same". The load average at the
start and the end is printed with it (the host may be shared with other jobs).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from string import Template

import numpy as np

ROOT = Path(__file__).resolve().parents[1]  # the working tree
POSE_TOL = 1e-12  # FK poses, Jacobians and Yoshikawa's index of the two sides
SOLUTION_TOL = 1e-9  # closed-form solution sets (rad), and numerical IK's joint vectors
REACH_TOL = 1e-9  # numerical IK: every answer's pose within this of its target (entries of T)
NOISE = 0.10  # a row is "slower" only when every round's ratio exceeds 1 + NOISE
CHECK_TIMEOUT = 3600  # s: the first check on a fresh checkout compiles its kernels
TIME_TIMEOUT = 900  # s per timing process

#: Import lines per API layout: "ik-package" (manipkit.ik, after issue 35), "closed-form-package" (before it).
IMPORTS = {
    "ik-package": {
        "ik": "from manipkit.ik.numerical import ik",
        "closed": "from manipkit.ik.chain_ik import chain_ik, chain_ik_many, srs_arm_angle\n"
                  "from manipkit.ik.families import chain_family",
    },
    "closed-form-package": {
        "ik": "from manipkit.kinematics.ik import ik",
        "closed": "from manipkit.closed_form.chain_ik import chain_ik, chain_ik_many, srs_arm_angle\n"
                  "from manipkit.closed_form.families import chain_family",
    },
}

#: Workload sizes: the full run, and ``--quick`` (seconds per process, for trying the script out).
SIZES = {
    "full": dict(n_fk=1000, n_batch=100_000, n_ik=200, n_cf=500, n_cf_batch=10_000, n_jac=100_000,
                 n_map=200_000, map_voxel=0.1, map_directions=50),
    "quick": dict(n_fk=20, n_batch=500, n_ik=5, n_cf=10, n_cf_batch=100, n_jac=500,
                  n_map=5_000, map_voxel=0.2, map_directions=10),
}

# Each child runs HARNESS with a workload's snippet in place of $snippet. A snippet calls
# add(key, calls, timed, answers): `timed()` is what is timed (`calls` calls or batch rows), `answers()`
# returns the dict of arrays compared between the sides (default: timed's own result).
HARNESS = '''
import gc, json, sys, time
import numpy as np
ROWS = []
def add(key, calls, timed, answers=None):
    ROWS.append((key, calls, timed, answers or timed))
def padded(sets, width):
    """Solution sets (one list of joint vectors per pose) as one (N, most, width) array, NaN where absent."""
    most = max([len(s) for s in sets] + [1])
    table = np.full((len(sets), most, width), np.nan)
    for i, s in enumerate(sets):
        if len(s):
            table[i, :len(s)] = np.asarray(s, dtype=float)
    return table
$snippet
def harness_main(mode, out, repeats):
    if mode == "check":
        arrays = {}
        for key, calls, timed, answers in ROWS:
            for name, value in answers().items():
                arrays[key + "|" + name] = np.asarray(value)
        np.savez(out, **arrays)
        return
    result = {}
    for key, calls, timed, answers in ROWS:
        timed()
        gc.collect()
        gc.disable()
        seconds = []
        for _ in range(repeats):
            start = time.perf_counter()
            timed()
            seconds.append(time.perf_counter() - start)
        gc.enable()
        result[key] = float(np.median(seconds)) / calls
    with open(out, "w") as handle:
        json.dump(result, handle)
harness_main(sys.argv[1], sys.argv[2], int(sys.argv[3]))
'''

#: workload -> (snippet, {row key: row label}); $-names are filled from IMPORTS and SIZES.
WORKLOADS = {
    "fk": ('''
import manipkit
robots = {name: manipkit.load(name) for name in ("iiwa14", "panda")}
iiwa = robots["iiwa14"]
Q1 = iiwa.sample_q($n_fk, seed=7)
def fk_single():
    return [iiwa.transform(iiwa.root_link, "ee_link", q) for q in Q1]
add("fk_single_iiwa14", $n_fk, fk_single, lambda: {"Q": Q1, "T": np.array(fk_single())})
for name, robot in robots.items():
    Q, ee = robot.sample_q($n_batch, seed=7), robot.frame("ee_link")
    add("fk_batch_" + name, $n_batch, lambda robot=robot, Q=Q, ee=ee: robot.fk(Q, tip=ee),
        lambda robot=robot, Q=Q, ee=ee: {"Q": Q, "T": robot.fk(Q, tip=ee)})
''', {"fk_single_iiwa14": "FK single, iiwa14 (Robot.transform, $n_fk calls)",
      "fk_batch_iiwa14": "FK batched, iiwa14 (Robot.fk, $n_batch rows)",
      "fk_batch_panda": "FK batched, panda (Robot.fk, $n_batch rows)"}),
    "ik": ('''
import manipkit
$ik
robot = manipkit.load("iiwa14")
Q_true, Q_start = robot.sample_q($n_ik, seed=11), robot.sample_q($n_ik, seed=12)
targets = [robot.transform(robot.root_link, "ee_link", q) for q in Q_true]
def solve():
    return [ik(robot, targets[i], q0=Q_start[i], seed=i) for i in range($n_ik)]
def answers():
    results = solve()
    q = np.array([r.q for r in results])
    T = np.array([robot.transform(robot.root_link, "ee_link", x, check_limits=False) for x in q])
    return {"q": q, "T": T, "target": np.array(targets), "success": np.array([bool(r.success) for r in results])}
add("ik_iiwa14", $n_ik, solve, answers)
''', {"ik_iiwa14": "numerical IK, iiwa14 ($n_ik targets, fixed starts)"}),
    "closed_single": ('''
import manipkit
$closed
robot = manipkit.load("ur5")
chain = robot.chain("base_link", "tool0")
family = chain_family(chain)
Q = chain.sample($n_cf, seed=13)
T = chain.fk(Q)
def single():
    return [chain_ik(chain, T[i], family=family) for i in range($n_cf)]
add("cf_single_ur5", $n_cf, single,
    lambda: {"Q": Q, "solutions": padded([[np.asarray(s) for s in r.solutions] for r in single()], Q.shape[1])})
''', {"cf_single_ur5": "closed form single, ur5 (chain_ik, all branches, $n_cf poses)"}),
    "closed_batch": ('''
import manipkit
$closed
ur5 = manipkit.load("ur5").chain("base_link", "tool0")
iiwa = manipkit.load("iiwa14").chain("base_link", "ee_link")
for name, chain, seed in (("ur5", ur5, 13), ("iiwa14", iiwa, 17)):
    family = chain_family(chain)
    Q = chain.sample($n_cf_batch, seed=seed)
    T = chain.fk(Q)
    psi = np.array([srs_arm_angle(chain, q, family=family) for q in Q]) if name == "iiwa14" else None
    def batch(chain=chain, family=family, T=T, psi=psi):
        extra = {} if psi is None else {"arm_angle": psi}
        result = chain_ik_many(chain, T, family=family, **extra)
        _ = result.success  # the FK check of every slot, timed with the call
        return result
    add("cf_batch_" + name, $n_cf_batch, batch, lambda batch=batch, Q=Q: {"Q": Q, "solutions": batch().solutions})
''', {"cf_batch_ur5": "closed form batched, ur5 (chain_ik_many, $n_cf_batch poses)",
      "cf_batch_iiwa14": "closed form batched, iiwa14 at arm angles (chain_ik_many, $n_cf_batch poses)"}),
    "jacobians": ('''
import manipkit
from manipkit.analysis.manipulability import manipulability
from manipkit.kinematics.jacobian import jacobians
for name in ("iiwa14", "panda"):
    robot = manipkit.load(name)
    Q, ee = robot.sample_q($n_jac, seed=19), robot.frame("ee_link")
    add("jac_" + name, $n_jac, lambda robot=robot, Q=Q, ee=ee: manipulability(jacobians(robot, Q, tip=ee), length=1.0),
        lambda robot=robot, Q=Q, ee=ee: {"Q": Q, "J": jacobians(robot, Q, tip=ee),
                                         "w": manipulability(jacobians(robot, Q, tip=ee), length=1.0)})
''', {"jac_iiwa14": "Jacobians + manipulability, iiwa14 ($n_jac rows)",
      "jac_panda": "Jacobians + manipulability, panda ($n_jac rows)"}),
    "reachmap": ('''
import manipkit
from manipkit.analysis import reachmap
robot = manipkit.load("iiwa14")
def build():
    return reachmap.build(robot, voxel=$map_voxel, orientations=$map_directions, samples=$n_map, method="fk")
def answers():
    built = build()
    return {"reach": built.reach, "cert_keys": built.cert_keys, "cert_q": built.cert_q}
add("reachmap_iiwa14", 1, build, answers)
''', {"reachmap_iiwa14": "reach map build, iiwa14 ($map_voxel m, $map_directions directions, $n_map samples)"}),
}
COLD_ARGS = ["base_link", "ee_link", "--robot", "course_arm"]
COLD_CODE = "import sys; from manipkit.app.cli import tf_between_main; sys.argv[0] = 'tf-between'; sys.exit(tf_between_main())"


class AgainstError(Exception):
    """A reference that cannot be checked out, a side whose layout is unknown, a child that failed."""


def layout(src: Path) -> str:
    """The API layout of the manipkit under ``src``: a key of :data:`IMPORTS`."""
    if (src / "manipkit" / "ik" / "chain_ik.py").is_file():
        return "ik-package"
    if (src / "manipkit" / "closed_form" / "chain_ik.py").is_file():
        return "closed-form-package"
    raise AgainstError(f"{src}: neither manipkit/ik/chain_ik.py nor manipkit/closed_form/chain_ik.py: unknown layout")


def child_source(workload: str, api: str, sizes: dict) -> str:
    """The program one child runs for ``workload`` on a side with layout ``api``."""
    snippet = Template(WORKLOADS[workload][0]).substitute(**IMPORTS[api], **sizes)
    return Template(HARNESS).substitute(snippet=snippet)


def row_labels(sizes: dict) -> dict:
    """Row key -> label, in table order."""
    return {key: Template(label).substitute(**sizes) for _, labels in WORKLOADS.values() for key, label in labels.items()}


def side_env(src: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(src)
    return env


def run_child(source: str, src: Path, args: list[str], timeout: float) -> None:
    result = subprocess.run([sys.executable, "-c", source, *args], env=side_env(src), cwd=src.parent,
                            capture_output=True, text=True, timeout=timeout)
    if result.returncode != 0:
        raise AgainstError(f"a child on {src} exited with {result.returncode}: {result.stderr.strip()[-1500:]}")


# --------------------------------------------------------------------------
# comparing the two sides' answers


def max_gap(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return float("inf")
    return float(np.max(np.abs(a - b))) if a.size else 0.0


def solution_set_gap(A: np.ndarray, B: np.ndarray) -> float:
    """Largest distance (max over joints) from a solution of one side to the nearest of the other's, same pose.

    ``A`` (N, k, n) and ``B`` (N, m, n) hold each pose's solutions, NaN rows where absent, in any order. A pose
    whose two sets differ in count gives ``inf``.
    """
    A, B = np.asarray(A, dtype=float), np.asarray(B, dtype=float)
    if A.shape[0] != B.shape[0] or A.shape[2] != B.shape[2]:
        return float("inf")
    in_a, in_b = ~np.isnan(A).any(axis=-1), ~np.isnan(B).any(axis=-1)
    if not np.array_equal(in_a.sum(axis=1), in_b.sum(axis=1)):
        return float("inf")
    if not in_a.any():
        return 0.0
    distance = np.abs(A[:, :, None, :] - B[:, None, :, :]).max(axis=-1)  # (N, k, m), NaN where a slot is absent
    distance = np.where(in_a[:, :, None] & in_b[:, None, :], distance, np.inf)
    nearest_b = np.where(in_a, distance.min(axis=2), 0.0)
    nearest_a = np.where(in_b, distance.min(axis=1), 0.0)
    return float(max(nearest_b.max(), nearest_a.max()))


def compare(key: str, old: dict, new: dict) -> tuple[bool, str]:
    """Whether the two sides agree on row ``key`` (its arrays by name), and the check in words."""
    if old.keys() != new.keys():
        return False, f"different answers kept: {sorted(old)} and {sorted(new)}"
    if "Q" in old and max_gap(old["Q"], new["Q"]) != 0.0:
        return False, "the two sides drew different inputs"
    if key.startswith("cf_"):
        gap = solution_set_gap(old["solutions"], new["solutions"])
        count = int((~np.isnan(new["solutions"]).any(axis=-1)).sum())
        return gap <= SOLUTION_TOL, f"{count} solutions; solution sets within {gap:.1e} (<= {SOLUTION_TOL:g})"
    if key.startswith("ik_"):
        reach = max(max_gap(side["T"][side["success"]], side["target"][side["success"]]) for side in (old, new))
        same_success = np.array_equal(old["success"], new["success"])
        gap = max_gap(old["q"], new["q"])
        ok = same_success and gap <= SOLUTION_TOL and reach <= REACH_TOL
        return ok, (f"{int(new['success'].sum())}/{new['success'].size} solved on both: {same_success}; joint vectors "
                    f"within {gap:.1e} (<= {SOLUTION_TOL:g}); answers' poses within {reach:.1e} of the targets")
    if key.startswith("reachmap"):
        same = all(np.array_equal(old[name], new[name]) for name in ("reach", "cert_keys"))
        gap = max_gap(old["cert_q"], new["cert_q"])
        ok = same and gap <= POSE_TOL
        return ok, (f"same reached voxel-bins and certificates: {same} ({int(np.count_nonzero(new['reach']))} "
                    f"voxel-bins); certificate configurations within {gap:.1e}")
    gaps = {name: max_gap(old[name], new[name]) for name in old if name != "Q"}
    worst = max(gaps.values())
    return worst <= POSE_TOL, "; ".join(f"{name} within {gap:.1e}" for name, gap in gaps.items()) + f" (<= {POSE_TOL:g})"


def check_workload(workload: str, sides: dict, sizes: dict, folder: Path) -> dict:
    """Row key -> (agrees, check in words), from one run per side of ``workload``."""
    arrays = {}
    for name, (src, api) in sides.items():
        out = folder / f"{workload}-{name}.npz"
        run_child(child_source(workload, api, sizes), src, ["check", str(out), "0"], CHECK_TIMEOUT)
        with np.load(out) as data:
            arrays[name] = {item: data[item] for item in data.files}
    checks = {}
    for key in WORKLOADS[workload][1]:
        old, new = ({item.split("|", 1)[1]: value for item, value in arrays[side].items()
                     if item.split("|", 1)[0] == key} for side in ("old", "new"))
        checks[key] = compare(key, old, new)
    return checks


# --------------------------------------------------------------------------
# timing in turns


def time_rounds(sides: dict, sizes: dict, rounds: int, repeats: int, folder: Path, say) -> dict:
    """Row key -> side -> per-round seconds per call (a list of ``rounds``)."""
    taken: dict = {}
    names = list(sides)
    for r in range(rounds):
        order = names if r % 2 == 0 else names[::-1]
        for workload in WORKLOADS:
            for name in order:
                src, api = sides[name]
                out = folder / f"time-{workload}-{name}.json"
                run_child(child_source(workload, api, sizes), src, ["time", str(out), str(repeats)], TIME_TIMEOUT)
                for key, seconds in json.loads(out.read_text()).items():
                    taken.setdefault(key, {}).setdefault(name, []).append(seconds)
        say(f"round {r + 1}/{rounds} done, load average {os.getloadavg()[0]:.2f}")
    return taken


def cold_start(sides: dict, runs: int) -> tuple[dict, str, bool]:
    """Side -> seconds of each fresh ``tf-between`` process (interleaved), the check in words, and whether it holds."""
    printed = {}
    for name, (src, _) in sides.items():  # untimed: writes the bytecode; its output is compared
        result = subprocess.run([sys.executable, "-c", COLD_CODE, *COLD_ARGS], env=side_env(src), capture_output=True,
                                text=True, timeout=300)
        if result.returncode != 0:
            raise AgainstError(f"tf-between on {src} exited with {result.returncode}: {result.stderr.strip()[-600:]}")
        printed[name] = np.array([float(x) for x in re.findall(r"-?\d+\.\d+(?:[eE][-+]?\d+)?", result.stdout)])
    gap = max_gap(printed["old"], printed["new"])
    ok = gap <= POSE_TOL and printed["new"].size > 0
    check = f"the {printed['new'].size} printed numbers of the two sides within {gap:.1e}"
    seconds: dict = {name: [] for name in sides}
    names = list(sides)
    for r in range(runs):
        for name in (names if r % 2 == 0 else names[::-1]):
            src = sides[name][0]
            start = time.perf_counter()
            subprocess.run([sys.executable, "-c", COLD_CODE, *COLD_ARGS], env=side_env(src), capture_output=True,
                           timeout=300, check=True)
            seconds[name].append(time.perf_counter() - start)
    return seconds, check, ok


# --------------------------------------------------------------------------
# the table


def verdict(ratios: np.ndarray) -> str:
    if np.all(ratios > 1.0 + NOISE):
        return "slower"
    if np.all(ratios < 1.0 - NOISE):
        return "faster"
    return "same"


def fmt_time(seconds: float) -> str:
    for scale, unit in ((1.0, "s"), (1e-3, "ms"), (1e-6, "us")):
        if seconds >= scale:
            return f"{seconds / scale:.3g} {unit}"
    return f"{seconds * 1e9:.3g} ns"


def table_rows(labels: dict, checks: dict, taken: dict, cold: tuple[dict, str, bool]) -> list[dict]:
    rows = []
    entries = [(key, labels[key], checks[key], taken.get(key, {})) for key in labels]
    seconds, cold_check, cold_ok = cold
    entries.append(("tf_between_cold", "`tf-between " + " ".join(COLD_ARGS) + "` cold start (one run)",
                    (cold_ok, cold_check), seconds))
    for key, label, (ok, check), per_side in entries:
        old, new = np.asarray(per_side.get("old", []), float), np.asarray(per_side.get("new", []), float)
        entry = {"key": key, "row": label, "ok": bool(ok), "check": check, "old_s": old.tolist(), "new_s": new.tolist()}
        if ok and old.size and new.size:
            ratios = new / old
            entry.update(old_median=float(np.median(old)), new_median=float(np.median(new)),
                         ratio=float(np.median(new) / np.median(old)), ratio_min=float(ratios.min()),
                         ratio_max=float(ratios.max()), verdict=verdict(ratios))
        rows.append(entry)
    return rows


def markdown(rows: list[dict], ref: str, sha: str, rounds: int, runs: int) -> str:
    name = ref if sha.startswith(ref) else f"{ref} ({sha[:7]})"
    lines = [f"| row | {name} | working tree | new/old | per-round new/old | verdict |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        if not r["ok"]:
            lines.append(f"| {r['row']} | WRONG | WRONG | - | - | {r['check']} |")
            continue
        lines.append(f"| {r['row']} | {fmt_time(r['old_median'])} | {fmt_time(r['new_median'])} | {r['ratio']:.2f} | "
                     f"{r['ratio_min']:.2f}-{r['ratio_max']:.2f} | {r['verdict']} |")
    lines.append("")
    lines.append(f"Times per call (or per batch row; per map; per run for the cold start): median over {rounds} rounds "
                 f"(cold start: over {runs} runs per side, the pair ratios' range in the per-round column). "
                 f"Verdict: slower/faster when every round's ratio is beyond {NOISE:.0%} of 1.")
    return "\n".join(lines)


# --------------------------------------------------------------------------
# the command


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.against", description=__doc__.split("\n\n")[0])
    parser.add_argument("ref", help="the commit (branch, tag) to time the working tree against")
    parser.add_argument("--rounds", type=int, default=5, help="rounds of timing, sides taking turns (default 5)")
    parser.add_argument("--repeats", type=int, default=3, help="timed calls per row per process (default 3)")
    parser.add_argument("--cold-runs", type=int, default=15, help="tf-between runs per side (default 15)")
    parser.add_argument("--quick", action="store_true", help="tiny sizes (to try the script, not to measure)")
    parser.add_argument("--out", type=Path, help="also write the rows as JSON here")
    args = parser.parse_args(argv)
    if min(args.rounds, args.repeats, args.cold_runs) < 1:
        parser.error("--rounds, --repeats and --cold-runs must be at least 1")
    return args


def git(*args: str) -> str:
    result = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True)
    if result.returncode != 0:
        raise AgainstError(f"git {' '.join(args)}: {result.stderr.strip()}")
    return result.stdout.strip()


def main(argv=None) -> int:
    args = parse_args(argv)

    def say(text: str) -> None:
        print(text, file=sys.stderr, flush=True)

    try:
        sha = git("rev-parse", "--verify", "--quiet", f"{args.ref}^{{commit}}")
    except AgainstError:
        print(f"against: {args.ref!r} is not a commit of {ROOT}", file=sys.stderr)
        return 2
    # a fixed path per commit: numba's kernel cache is keyed by source path, so a second run reuses its kernels
    tree = Path(tempfile.gettempdir()) / f"manipkit-against-{sha[:12]}"
    if tree.exists():
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)], capture_output=True)
        shutil.rmtree(tree, ignore_errors=True)
    git("worktree", "add", "--detach", str(tree), sha)
    try:
        sides = {"old": (tree / "src", layout(tree / "src")), "new": (ROOT / "src", layout(ROOT / "src"))}
        sizes = SIZES["quick" if args.quick else "full"]
        labels = row_labels(sizes)
        load_start = os.getloadavg()
        started = time.time()
        with tempfile.TemporaryDirectory() as folder:
            checks = {}
            for workload in WORKLOADS:
                say(f"checking {workload} on both sides (a fresh checkout compiles its kernels first: minutes)")
                checks.update(check_workload(workload, sides, sizes, Path(folder)))
            for key, (ok, check) in checks.items():
                say(f"  {key}: {'agrees' if ok else 'WRONG'}: {check}")
            taken = time_rounds(sides, sizes, args.rounds, args.repeats, Path(folder), say)
        say("cold start")
        cold = cold_start(sides, args.cold_runs)
        load_end = os.getloadavg()
        rows = table_rows(labels, checks, taken, cold)
        print(f"{args.ref} ({sha[:7]}, {sides['old'][1]}) against the working tree ({sides['new'][1]}), "
              f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime(started))}; load average (1, 5, 15 min) "
              f"{'/'.join(f'{x:.2f}' for x in load_start)} at the start, {'/'.join(f'{x:.2f}' for x in load_end)} "
              f"at the end, {os.cpu_count()} cores; {time.time() - started:.0f} s\n")
        print(markdown(rows, args.ref, sha, args.rounds, args.cold_runs))
        for r in rows:
            print(f"- {r['row']}: {r['check']}")
        if args.out:
            args.out.write_text(json.dumps({"ref": args.ref, "sha": sha, "load_start": load_start,
                                            "load_end": load_end, "rows": rows}, indent=1), encoding="utf-8")
    except (AgainstError, subprocess.SubprocessError) as exc:
        print(f"against: {exc}", file=sys.stderr)
        return 1
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)], capture_output=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
