"""Shared by the reader checks (check_meshio.py, check_contacts.py): a fresh work directory, running polydem,
and recording failed checks so a script reports all of them before it exits non-zero."""
import os
import shutil
import subprocess

failures = []
polydem = None


def start(argv):
    """argv = [script, POLYDEM, WORKDIR]: empty WORKDIR (made afresh) becomes the current directory."""
    global polydem
    polydem, work = argv[1], argv[2]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    os.chdir(work)


def run(*args):
    r = subprocess.run([polydem, *args], capture_output=True, text=True)
    if r.returncode != 0:
        print(r.stdout, r.stderr)
        raise SystemExit(f"FAIL: polydem {' '.join(args)} exited {r.returncode}")
    return r.stdout


def check(condition, what):
    print(("ok   " if condition else "FAIL ") + what)
    if not condition:
        failures.append(what)
