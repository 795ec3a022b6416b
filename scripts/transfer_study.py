#!/usr/bin/env python3
"""A signature fitted on the UR10's series C used on another series (docs/explanation/transfer.md).

Through the program as a lab runs it: series C imported as one session, COUNT poses of the
other series as a second (the new set-up), `recalibrate`, then `predict --frame measurement`
on that series' other poses; prints their mean error distance (mm), and how many lie outside
the residual map's support.

  scripts/transfer_study.py 30                      # B, 30 spread placing poses, the job's defaults
  scripts/transfer_study.py 10 --orientation off    # positions only
  scripts/transfer_study.py 30 --select 2790 --tool-rotation shared --series D --layout first

ARMSIG names the program (default build/armsig).
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "tests", "data", "ur10-ipa")
SERIES = {"B": "series_B-measurements_joint_configurations.csv",
          "D": "series_D-measurements_iso_cubes.csv"}
JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
          "wrist_2_joint", "wrist_3_joint"]
POSITION = ["measurement_x", "measurement_y", "measurement_z"]


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("count", type=int, help="placing poses of the new series")
    p.add_argument("--series", choices=sorted(SERIES), default="B")
    p.add_argument("--layout", choices=["spread", "first"], default="spread",
                   help="spread through the file, or its first rows (one line of the robot)")
    p.add_argument("--orientation", choices=["auto", "off"], default="auto")
    p.add_argument("--tool-rotation", choices=["per-session", "shared"], default="per-session")
    p.add_argument("--params", default="auto")
    p.add_argument("--select", type=int, default=0, help="configurations to fit (0: the job's own)")
    a = p.parse_args()
    armsig = os.environ.get("ARMSIG", os.path.join(ROOT, "build", "armsig"))
    work = tempfile.mkdtemp(prefix="armsig-transfer-")
    db = ["--db", os.path.join(work, "lab.db")]

    def run(args):
        r = subprocess.run([armsig] + db + args, capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"armsig {' '.join(args)} exited {r.returncode}:\n{r.stderr[-2000:]}")

    path = os.path.join(DATA, SERIES[a.series])
    if not os.path.exists(path):
        sys.exit(f"{path}: not in tests/data/ur10-ipa (copy it there unchanged, with its source)")
    run(["robot", "add", "ur10", "--model", os.path.join(ROOT, "models", "ur10.yaml")])
    run(["import", "poses", os.path.join(DATA, "series_C-measurements_random_poses.csv"),
         "--preset", "ur-ipa", "--robot", "ur10"])
    lines = open(path).read().splitlines()
    head, rows = lines[0], lines[1:]
    n = len(rows)
    placing = (set(range(a.count)) if a.layout == "first"
               else {int((k + 0.5) * n / a.count) for k in range(a.count)})
    with open(os.path.join(work, "place.csv"), "w") as f:
        f.write(head + "\n" + "\n".join(rows[i] for i in sorted(placing)) + "\n")
    run(["import", "poses", os.path.join(work, "place.csv"), "--preset", "ur-ipa", "--robot", "ur10"])
    columns = head.split(";")
    jc = [columns.index(c) for c in JOINTS]
    xc = [columns.index(c) for c in POSITION]
    rest = [i for i in range(n) if i not in placing]
    with open(os.path.join(work, "rest.csv"), "w") as f:
        f.write("pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n")
        for i in rest:
            v = rows[i].split(";")
            f.write(f"p{i}," + ",".join("%.15g" % math.degrees(float(v[c].replace(",", ".")))
                                        for c in jc) + "\n")
    night = os.path.join(work, "night.json")
    run(["recalibrate", "--robot", "ur10", "--params", a.params, "--select", str(a.select),
         "--orientation", a.orientation, "--tool-rotation", a.tool_rotation, "--json", night])
    decision = json.load(open(night)).get("decision")
    predicted = os.path.join(work, "predicted.csv")
    run(["predict", "--robot", "ur10", "--frame", "measurement", "--joints",
         os.path.join(work, "rest.csv"), "--out", predicted])
    total = outside = 0.0
    for i, row in zip(rest, csv.DictReader(open(predicted))):
        v = rows[i].split(";")
        measured = [float(v[c].replace(",", ".")) for c in xc]
        total += math.dist(measured, [float(row["x_mm"]), float(row["y_mm"]), float(row["z_mm"])])
        outside += row.get("map") == "outside"
    print(f"series {a.series}, {a.count} {a.layout} placing poses, orientation {a.orientation}, "
          f"tool rotation {a.tool_rotation}, select {a.select or 'default'}: mean "
          f"{total / len(rest):.3f} mm on {len(rest)} poses ({int(outside)} outside the map); "
          f"decision {decision}; files in {work}")


if __name__ == "__main__":
    main()
