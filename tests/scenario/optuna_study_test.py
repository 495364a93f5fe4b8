#!/usr/bin/python3
"""The Optuna example end to end (programs/examples/optuna/walk_study.py local): its own PostgreSQL 15, two
worker processes sharing one study, every trial a `doppel scenario run` of the walk. Checks that
every trial completed with a result from a real run, that both workers took trials from the one
study, that the baseline came first, and that PostgreSQL and its directory are gone afterwards.
Usage: optuna_study_test.py DOPPEL"""
import glob
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
STUDY = os.path.join(HERE, "..", "..", "programs", "examples", "optuna", "walk_study.py")
TRIALS = 6

before = set(glob.glob(os.path.join(tempfile.gettempdir(), "doppel-study-*")))
run = subprocess.run([sys.executable, STUDY, "local", "--workers", "2", "--trials", str(TRIALS), "--duration", "5",
                      "--doppel", sys.argv[1]], capture_output=True, text=True, timeout=600)
sys.stderr.write(run.stderr[-3000:])
assert run.returncode == 0, "walk_study.py local exited %d" % run.returncode
result = json.loads(run.stdout)
print(json.dumps(result, indent=1))
assert result["trials"] == TRIALS and result["complete"] == TRIALS and result["failed"] == 0, result
assert result["worker_exit_codes"] == [0, 0], result
assert result["first"]["number"] == 0 and result["first"]["params"] == {"speed": 0.05, "period": 0.5}, result["first"]
workers = {t["worker"] for t in result["all"]}
assert len(workers) == 2, "both workers took trials from the one study: %s" % workers
for t in result["all"]:
    # A standing run scores its forward speed (|v| well below 1 m/s); a fall -1 + the part it stood.
    assert (t["value"] > -1.0 and t["value"] < 0.0) if t["fallen"] else abs(t["value"]) < 1.0, t
    assert t["forward_m"] is not None and t["wall_time_s"] > 0, t
assert result["best"]["value"] >= result["first"]["value"]
left = set(glob.glob(os.path.join(tempfile.gettempdir(), "doppel-study-*"))) - before
assert not left, "the study's PostgreSQL directory was not removed: %s" % left
print("ok")
