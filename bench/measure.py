#!/usr/bin/env python3
"""Runs one command and records what the whole process cost, for the bench scripts.

Usage: bench/measure.py OUT.json -- COMMAND [ARGS...]

Writes {"command", "exit_code", "wall_seconds", "user_seconds", "sys_seconds", "cpu_seconds",
"max_rss_bytes"} to OUT.json, from the child's own rusage (os.wait4), so the numbers are the
command's alone. Exits with the command's exit code; its stdout and stderr pass through.
"""
import json
import os
import subprocess
import sys
import time


def main():
    if len(sys.argv) < 4 or sys.argv[2] != "--":
        sys.exit("usage: measure.py OUT.json -- COMMAND [ARGS...]")
    out, command = sys.argv[1], sys.argv[3:]
    start = time.monotonic()
    child = subprocess.Popen(command)
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.monotonic() - start
    code = os.waitstatus_to_exitcode(status)
    child.returncode = code  # reaped by wait4: keep Popen from waiting again
    record = {
        "command": command,
        "exit_code": code,
        "wall_seconds": wall,
        "user_seconds": usage.ru_utime,
        "sys_seconds": usage.ru_stime,
        "cpu_seconds": usage.ru_utime + usage.ru_stime,
        "max_rss_bytes": usage.ru_maxrss * 1024,  # Linux reports kilobytes
    }
    with open(out, "w") as f:
        json.dump(record, f, indent=2)
        f.write("\n")
    sys.exit(code if code >= 0 else 128 - code)


if __name__ == "__main__":
    main()
