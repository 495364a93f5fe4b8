#!/usr/bin/python3
"""Tunes the reference walk (doppel-walk) for speed without falling: an Optuna study whose trials are
`doppel scenario run data/scenarios/walk-forward.textproto` runs and whose storage is PostgreSQL, so any
number of worker processes on any number of machines share one study (docs/scenarios.md).

  walk_study.py local  --workers 2 --trials 8        # own PostgreSQL, N local workers, summary JSON
  walk_study.py server --dir /srv/study --listen 0.0.0.0 --allow 10.1.0.0/16   # PostgreSQL for a cluster
  walk_study.py worker --storage URL --trials 4      # one worker (a Slurm array task, an ssh'd machine)

Parameters: the walk's commanded speed (`--speed`, m/s: each step is stride_scale x speed x period / 2
long) and its cycle period (`--period`, s: two steps per period, so the step frequency is 2 / period).
Objective: forward speed (m/s along the start heading over the run) for a run that ends standing;
a fall scores FALL_PENALTY plus the fraction of the run it stood, so every fall ranks below every
standing run and later falls above earlier ones. The first trial is the walk's defaults (speed
0.05, period 0.5): the baseline the study should beat.
"""
import argparse
import json
import os
import pwd
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

import optuna

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
DEFAULT_SCENARIO = os.path.join(SOURCE, "data", "scenarios", "walk-forward.textproto")
PG_BIN = "/usr/lib/postgresql/15/bin"  # Debian postgresql-15
STUDY = "walk-forward"
FALL_PENALTY = -1.0
SPEED_RANGE = (0.02, 0.14)   # doppel-walk accepts -0.2..0.2 m/s
PERIOD_RANGE = (0.35, 0.8)   # and 0.2..2 s
BASELINE = {"speed": 0.05, "period": 0.5}


# ---- PostgreSQL of its own -------------------------------------------------------------------

def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def as_db_user(argv, user):
    """PostgreSQL refuses to run as root: as root, run its programs as `user`."""
    return ["runuser", "-u", user, "--"] + argv if os.geteuid() == 0 else argv


class Postgres:
    """A PostgreSQL cluster in `directory` (created with initdb when new), listening on a Unix socket
    in it and, with `listen`, on that address. Local connections are trusted (the socket lives in a
    0700 directory); TCP needs the generated password (scram-sha-256), from `allow` (CIDR) only."""

    def __init__(self, directory, port=None, listen="", allow=(), user="postgres"):
        self.dir = os.path.abspath(directory)
        self.data = os.path.join(self.dir, "data")
        self.port = port or free_port()
        self.listen = listen
        self.user = user if os.geteuid() == 0 else pwd.getpwuid(os.geteuid()).pw_name
        self.password_file = os.path.join(self.dir, "password")
        os.makedirs(self.dir, mode=0o700, exist_ok=True)
        if os.geteuid() == 0:
            entry = pwd.getpwnam(self.user)
            os.chown(self.dir, entry.pw_uid, entry.pw_gid)
        if not os.path.exists(os.path.join(self.data, "PG_VERSION")):
            with open(self.password_file, "w") as f:
                f.write(secrets.token_urlsafe(18))
            if os.geteuid() == 0:
                os.chown(self.password_file, entry.pw_uid, entry.pw_gid)
            subprocess.run(as_db_user([os.path.join(PG_BIN, "initdb"), "-D", self.data, "-U", "doppel",
                                       "--auth-local=trust", "--auth-host=scram-sha-256",
                                       "--pwfile=" + self.password_file], self.user),
                           check=True, stdout=subprocess.DEVNULL)
            if allow:
                with open(os.path.join(self.data, "pg_hba.conf"), "a") as hba:
                    for cidr in allow:
                        hba.write("host all doppel %s scram-sha-256\n" % cidr)
        with open(self.password_file) as f:
            self.password = f.read().strip()

    def start(self):
        options = "-p %d -k %s -c listen_addresses='%s' -c max_connections=200" % (self.port, self.dir, self.listen)
        subprocess.run(as_db_user([os.path.join(PG_BIN, "pg_ctl"), "-D", self.data, "-l",
                                   os.path.join(self.dir, "postgres.log"), "-w", "-o", options, "start"], self.user),
                       check=True, stdout=subprocess.DEVNULL)
        import psycopg2
        connection = psycopg2.connect(dbname="postgres", user="doppel", host=self.dir, port=self.port)
        connection.autocommit = True
        with connection.cursor() as cursor:
            cursor.execute("SELECT 1 FROM pg_database WHERE datname = 'optuna'")
            if cursor.fetchone() is None:
                cursor.execute("CREATE DATABASE optuna")
        connection.close()

    def stop(self):
        subprocess.run(as_db_user([os.path.join(PG_BIN, "pg_ctl"), "-D", self.data, "-m", "fast", "-w", "stop"],
                                  self.user), check=False, stdout=subprocess.DEVNULL)

    def local_url(self):
        return "postgresql+psycopg2://doppel@/optuna?host=%s&port=%d" % (self.dir, self.port)

    def tcp_url(self, host):
        return "postgresql+psycopg2://doppel:%s@%s:%d/optuna" % (self.password, host, self.port)


# ---- the trials -------------------------------------------------------------------------------

def objective_of(result):
    """Forward speed for a run that ends standing; a fall ranks below every standing run."""
    metrics = result["metrics"][0]
    duration = result["sim_time_s"] or result["duration_s"]
    if metrics["fallen"]:
        return FALL_PENALTY + metrics["time_to_fall_s"] / result["duration_s"]
    return metrics["forward_m"] / duration


def make_objective(args):
    def objective(trial):
        speed = trial.suggest_float("speed", *SPEED_RANGE)
        period = trial.suggest_float("period", *PERIOD_RANGE)
        command = [args.doppel, "scenario", "run", args.scenario, "--seed", str(trial.number),
                   "--param", "speed=%.4f" % speed, "--param", "period=%.4f" % period]
        if args.duration:
            command += ["--duration", str(args.duration)]
        started = time.monotonic()
        run = subprocess.run(command, capture_output=True, text=True)
        if run.returncode != 0:
            raise RuntimeError("doppel scenario run failed (%d): %s" % (run.returncode, run.stderr.strip()))
        result = json.loads(run.stdout)
        metrics = result["metrics"][0]
        trial.set_user_attr("forward_m", metrics["forward_m"])
        trial.set_user_attr("fallen", metrics["fallen"])
        trial.set_user_attr("time_to_fall_s", metrics["time_to_fall_s"])
        trial.set_user_attr("energy_drawn_j", metrics["energy_drawn_j"])
        trial.set_user_attr("sim_time_s", result["sim_time_s"])
        trial.set_user_attr("wall_time_s", time.monotonic() - started)
        trial.set_user_attr("host", socket.gethostname())
        trial.set_user_attr("worker", "%s/%d" % (socket.gethostname(), os.getpid()))
        return objective_of(result)
    return objective


def create_study(storage, seed):
    study = optuna.create_study(study_name=STUDY, storage=storage, direction="maximize", load_if_exists=True,
                                sampler=optuna.samplers.TPESampler(seed=seed, n_startup_trials=4))
    if len(study.trials) == 0:
        study.enqueue_trial(BASELINE)
    return study


def work(args):
    """One worker: takes trials from the shared study until it has run `--trials`."""
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    # Each worker its own sampler seed, so two workers do not propose the same point.
    seed = args.seed + 1000 * (args.worker_index or int(os.environ.get("SLURM_ARRAY_TASK_ID", "0")))
    study = optuna.load_study(study_name=STUDY, storage=args.storage,
                              sampler=optuna.samplers.TPESampler(seed=seed, n_startup_trials=4))
    study.optimize(make_objective(args), n_trials=args.trials)


def summary(storage):
    study = optuna.load_study(study_name=STUDY, storage=storage)
    done = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    done.sort(key=lambda t: t.number)
    first = done[0] if done else None
    best = study.best_trial if done else None
    def row(t):
        return {"number": t.number, "value": t.value, "params": t.params, "forward_m": t.user_attrs.get("forward_m"),
                "fallen": t.user_attrs.get("fallen"), "wall_time_s": t.user_attrs.get("wall_time_s"),
                "worker": t.user_attrs.get("worker")}
    return {"study": STUDY, "trials": len(study.trials), "complete": len(done),
            "failed": sum(t.state == optuna.trial.TrialState.FAIL for t in study.trials),
            "first": row(first) if first else None, "best": row(best) if best else None,
            "best_beats_first": bool(best and first and best.value > first.value),
            "all": [row(t) for t in done]}


# ---- commands ---------------------------------------------------------------------------------

def local(args):
    started = time.monotonic()
    directory = args.dir or tempfile.mkdtemp(prefix="doppel-study-")
    database = Postgres(directory)
    database.start()
    try:
        storage = database.local_url()
        create_study(storage, args.seed)
        workers = []
        for w in range(args.workers):
            command = [sys.executable, os.path.abspath(__file__), "worker", "--storage", storage,
                       "--trials", str(args.trials // args.workers + (1 if w < args.trials % args.workers else 0)),
                       "--doppel", args.doppel, "--scenario", args.scenario, "--seed", str(args.seed),
                       "--worker-index", str(w + 1)]
            if args.duration:
                command += ["--duration", str(args.duration)]
            workers.append(subprocess.Popen(command))
        codes = [w.wait() for w in workers]
        result = summary(storage)
        result["workers"] = args.workers
        result["worker_exit_codes"] = codes
        result["wall_time_s"] = time.monotonic() - started
        print(json.dumps(result))
        return 0 if all(c == 0 for c in codes) else 1
    finally:
        database.stop()
        if not args.dir and not args.keep:
            shutil.rmtree(directory, ignore_errors=True)


def server(args):
    database = Postgres(args.dir, port=args.port, listen=args.listen, allow=args.allow)
    database.start()
    create_study(database.local_url(), args.seed)
    host = args.host or socket.getfqdn()
    print("storage (this machine): %s" % database.local_url())
    print("storage (workers):      %s" % database.tcp_url(host), flush=True)
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    try:
        while not stop:
            time.sleep(1)
    except KeyboardInterrupt:
        pass
    print(json.dumps(summary(database.local_url())))
    database.stop()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = parser.add_subparsers(dest="command", required=True)
    def run_options(p):
        p.add_argument("--doppel", default=shutil.which("doppel") or os.path.join(SOURCE, "build", "gateway", "doppel"))
        p.add_argument("--scenario", default=DEFAULT_SCENARIO)
        p.add_argument("--duration", type=float, help="simulated seconds per trial (default: the scenario's)")
        p.add_argument("--seed", type=int, default=1)
    p = commands.add_parser("local", help="own PostgreSQL, N workers on this machine, summary JSON on stdout")
    run_options(p)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--trials", type=int, default=8, help="trials in all")
    p.add_argument("--dir", help="PostgreSQL's directory (default: a temporary one, removed)")
    p.add_argument("--keep", action="store_true", help="keep the temporary directory")
    p = commands.add_parser("server", help="PostgreSQL and the study for workers elsewhere; runs until SIGTERM/^C")
    run_options(p)
    p.add_argument("--dir", required=True)
    p.add_argument("--port", type=int, default=5432)
    p.add_argument("--listen", default="", help="address to listen on ('' = Unix socket only; 0.0.0.0 = every)")
    p.add_argument("--allow", action="append", default=[], help="CIDR workers connect from (repeatable)")
    p.add_argument("--host", help="this machine's name as workers reach it (default: its FQDN)")
    p = commands.add_parser("worker", help="run trials of the shared study")
    run_options(p)
    p.add_argument("--storage", required=True, help="the server's storage URL")
    p.add_argument("--trials", type=int, default=4, help="trials this worker runs")
    p.add_argument("--worker-index", type=int, default=0, help="seeds its sampler (default: $SLURM_ARRAY_TASK_ID)")
    args = parser.parse_args()
    if args.command == "local":
        return local(args)
    if args.command == "server":
        return server(args)
    work(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
