#!/usr/bin/python3
"""Real CT as a standing check (issue 41): every real slice of ../shared/realdata as short scans.

  bench/real_slices.py [--sawyer BIN] [--data DIR] [--work DIR] [--quick] [--jobs N]
                       [--json OUT] [--min-pass N] [--keep]

The real slices and their hand labels live outside the repository (../shared/realdata; their
licence keeps them, and anything made from them, out of it). Without that folder this prints
"skipped" and exits 0, which is what a user's clone gets.

Cases: every PNG slice x seeds 1-5, with and without an 8 px pith drift (the data's own
make_case.py: 60 copies 5 mm apart, each shifted by 0.5-1 px with noise), and the real dried
disc as written (a coronal DICOM series), axial, and axial at +400 HU. --quick: seed 1 only
(11 cases). Each case is scanned by `sawyer scan` and scored by the data's score.py (pith per
slice against the label, the outer surface against the image's own edge on 360 rays, the knot
count, the QA verdict).

Targets (issue 41): every case pith median <= 1.5 mm and p95 <= 3 mm; outer surface median
<= 2 mm; at most 5 knots on a section of rings alone (DOU1B's strong latewood) and none on the
knot-free disc; the QA verdict right (trusted exactly where the pith and outline targets hold).

--min-pass N exits 1 when fewer than N cases meet every target, or when any case fails to scan:
the CTest (RealSlices) holds the floor the code has reached, so a change that loses a real case
fails the suite.
"""
import argparse, concurrent.futures, json, os, shutil, subprocess, sys, tempfile, time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
PYTHON = "/usr/bin/python3" if os.path.exists("/usr/bin/python3") else sys.executable

p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
p.add_argument("--sawyer", default=os.path.join(ROOT, "build", "apps", "sawyer", "sawyer"))
p.add_argument("--data", default=os.path.join(ROOT, "..", "shared", "realdata"))
p.add_argument("--work", help="folder for the cases and scans: new, empty or one this bench made "
               "(default: a temporary one)")
p.add_argument("--quick", action="store_true", help="seed 1 only (11 cases)")
p.add_argument("--jobs", type=int, default=2, help="cases made and scanned at once")
p.add_argument("--only", help="comma-separated case name prefixes")
p.add_argument("--json", help="write every case's figures here")
p.add_argument("--min-pass", type=int, help="fail unless at least this many cases meet every target")
p.add_argument("--keep", action="store_true", help="keep the work folder (and the cases in it: a later run with the same --work scans them again without making them anew)")
a = p.parse_args()

data = os.path.abspath(a.data)
if not os.path.isfile(os.path.join(data, "labels.json")):
    print(f"real_slices: skipped: no real CT data at {data} (../shared/realdata is not part of a clone)")
    sys.exit(0)
missing = []
for mod in ("numpy", "scipy", "PIL", "pydicom"):
    r = subprocess.run([PYTHON, "-c", f"import {mod}"], capture_output=True)
    if r.returncode:
        missing.append(mod)
if missing:
    print(f"real_slices: skipped: {PYTHON} lacks {', '.join(missing)} "
          "(Debian: python3-numpy python3-scipy python3-pil python3-pydicom; scripts/install_deps.sh)")
    sys.exit(0)
if not os.access(a.sawyer, os.X_OK):
    sys.exit(f"real_slices: {a.sawyer}: not built (cmake --build build --target sawyer)")

labels = json.load(open(os.path.join(data, "labels.json")))
pngs = sorted(k for k in labels if k.endswith(".png"))
seeds = [1] if a.quick else [1, 2, 3, 4, 5]
cases = []  # (name, slice file, make_case flags, knot limit)
for s in pngs:
    stem = os.path.splitext(s)[0].lower()
    # A section of rings alone: the slice's notes say so (strong latewood, no knots).
    notes = labels[s].get("notes", "")
    ring_only = "ring-only" in notes or "no knots" in notes
    for seed in seeds:
        for drift in (0, 8):
            flags = ["--jitter", "--seed", str(seed)] + (["--drift", str(drift)] if drift else [])
            cases.append((f"{stem}_s{seed}{'_drift' if drift else ''}", s, flags, 5 if ring_only else None))
disc = "CTRing_disk.dcm"
if disc in labels:
    cases.append(("disc_coronal", disc, ["--jitter", "--seed", "1"], 0))
    cases.append(("disc_axial", disc, ["--jitter", "--seed", "1", "--axial"], 0))
    cases.append(("disc_axial_400hu", disc, ["--jitter", "--seed", "1", "--axial", "--hu-offset", "400"], 0))
if a.only:
    keep = a.only.split(",")
    cases = [c for c in cases if any(c[0].startswith(k) for k in keep)]

work = a.work or tempfile.mkdtemp(prefix="sawyer_real_")
# The cases and scans are made and removed by name inside the work folder: only in one this
# bench made (its marker file), never in a folder that holds anything else.
MARKER = os.path.join(work, ".sawyer_real_slices")
if os.path.isdir(work) and os.listdir(work) and not os.path.exists(MARKER):
    sys.exit(f"real_slices: {work}: not empty and not a real_slices work folder; give an empty or new one")
os.makedirs(work, exist_ok=True)
open(MARKER, "w").close()


def run_case(case):
    name, src, flags, knot_limit = case
    d = os.path.join(work, name)
    scan = d + "_scan"
    made = a.keep and os.path.isfile(d + ".truth.json") and os.path.isdir(d)
    r = subprocess.run([PYTHON, os.path.join(data, "make_case.py"), os.path.join(data, "slices", src), d] + flags,
                       capture_output=True, text=True) if not made else subprocess.CompletedProcess([], 0)
    if r.returncode:
        return {"case": name, "error": "make_case: " + (r.stderr.strip().splitlines() or ["?"])[-1]}
    if os.path.exists(scan):
        shutil.rmtree(scan)
    t0 = time.monotonic()
    r = subprocess.run([a.sawyer, "scan", d, "-o", scan], capture_output=True, text=True)
    secs = time.monotonic() - t0
    # Exit 3: written whole, but the QA verdict failed (docs/scan.md); scored like the rest.
    if r.returncode not in (0, 3) or not os.path.isfile(os.path.join(scan, "log.json")):
        msg = (r.stderr.strip().splitlines() or ["exit %d" % r.returncode])[-1]
        return {"case": name, "error": "scan: " + msg, "seconds": secs}
    out = os.path.join(work, name + ".score.json")
    r = subprocess.run([PYTHON, os.path.join(data, "score.py"), scan, d + ".truth.json", "--json", out, "--data", data],
                       capture_output=True, text=True)
    if r.returncode:
        return {"case": name, "error": "score: " + (r.stderr.strip().splitlines() or ["?"])[-1]}
    res = json.load(open(out))
    res["case"] = name
    res["seconds"] = secs
    res["knot_limit"] = knot_limit
    # What the scan said about its pith: the cue and expected error of the QA verdict.
    try:
        L = json.load(open(os.path.join(scan, "log.json")))
        qa = L.get("qa") or {}
        res["qa_failed_stages"] = [st.get("stage", "") for st in qa.get("stages", []) if not st.get("ok", True)]
        res["qa_warning"] = (qa.get("warnings") or [""])[0]
    except (OSError, ValueError):
        res["qa_failed_stages"], res["qa_warning"] = [], ""
    if not a.keep:
        shutil.rmtree(d, ignore_errors=True)
        shutil.rmtree(scan, ignore_errors=True)
    return res


t0 = time.monotonic()
with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, a.jobs)) as ex:
    results = list(ex.map(run_case, cases))
wall = time.monotonic() - t0


def verdict(r):
    """Which targets the case meets: pith, outline, knots; QA right."""
    pith = r["pith_median_mm"] <= 1.5 and r["pith_p95_mm"] <= 3.0
    outline = r["outline_median_mm"] <= 2.0
    knots = r["knot_limit"] is None or r["knots"] <= r["knot_limit"]
    trusted = r["qa"] == "trusted"
    qa_right = trusted == (pith and outline)
    return pith, outline, knots, qa_right


yes = lambda b: "yes" if b else "**no**"
print(f"# Real CT slices: {len(results)} cases, {a.jobs} at once, {wall:.0f} s wall")
print()
print("| case | pith med mm | pith p95 mm | outline med mm | within 3 mm | knots | QA | pith | outline | knots ok | QA right | scan s |")
print("|---|---:|---:|---:|---:|---:|---|---|---|---|---|---:|")
passed = errors = 0
tally = {"pith": 0, "outline": 0, "knots": 0, "qa": 0}
n_ok = 0
for r in results:
    if "error" in r:
        errors += 1
        print(f"| {r['case']} | {r['error']} |")
        continue
    n_ok += 1
    pith, outline, knots, qa_right = verdict(r)
    for k, v in zip(("pith", "outline", "knots", "qa"), (pith, outline, knots, qa_right)):
        tally[k] += v
    passed += pith and outline and knots and qa_right
    lim = "" if r["knot_limit"] is None else f" (≤ {r['knot_limit']})"
    print(f"| {r['case']} | {r['pith_median_mm']:.2f} | {r['pith_p95_mm']:.2f} | {r['outline_median_mm']:.2f} | "
          f"{100 * r['outline_within_3mm']:.0f} % | {r['knots']}{lim} | {r['qa']} | {yes(pith)} | {yes(outline)} | "
          f"{yes(knots)} | {yes(qa_right)} | {r['seconds']:.1f} |")
n = len(results)
print()
print(f"- pith median <= 1.5 mm and p95 <= 3 mm: {tally['pith']} of {n} cases {'(met)' if tally['pith'] == n else '(missed)'}")
print(f"- outer surface median <= 2 mm: {tally['outline']} of {n} {'(met)' if tally['outline'] == n else '(missed)'}")
print(f"- knots <= 5 on ring-only sections, 0 on the disc: {tally['knots']} of {n} {'(met)' if tally['knots'] == n else '(missed)'}")
print(f"- QA verdict right (trusted exactly where pith and outline meet their targets): {tally['qa']} of {n} "
      f"{'(met)' if tally['qa'] == n else '(missed)'}")
print(f"- scans refused or failed: {errors}")
print(f"- every target: {passed} of {n} cases")
if a.json:
    json.dump({"cases": results, "passed": passed, "errors": errors, "wall_s": wall}, open(a.json, "w"), indent=1)
if not a.keep and not a.work:
    shutil.rmtree(work, ignore_errors=True)
if a.min_pass is not None and (errors or passed < a.min_pass):
    print(f"real_slices: FAILED: {passed} cases meet every target (floor {a.min_pass}), {errors} failed to scan")
    sys.exit(1)
