"""What doppel's Python end-to-end tests share: their failure, its check, stopping the doppel they
started (SIGINT as a user's ^C, then SIGKILL after 30 s) and their main().

A test puts this folder on sys.path and imports it:
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
"""
import shutil
import signal
import subprocess
import sys


class Failure(Exception):
    pass


def check(condition, message):
    if not condition:
        raise Failure(message)


def stop_doppel(process, work):
    """Stops `process` (a doppel this test started, or None) and removes the test's folder `work`."""
    if process is not None and process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
    shutil.rmtree(work, ignore_errors=True)


def script_test_main(name, doc, argument_count, run):
    """Runs `run(*arguments)` with the command line's `argument_count` arguments: 0 passed, 1 failed
    (a Failure, printed), 2 bad usage (prints `doc`)."""
    if len(sys.argv) != argument_count + 1:
        print(doc)
        return 2
    try:
        run(*sys.argv[1:])
    except Failure as failure:
        print(f"{name}: FAILED: {failure}")
        return 1
    return 0
