"""Ctrl-C during a long solve or solve_many: KeyboardInterrupt soon after, no crash, no threads
left behind (a child process gets SIGINT)."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

CHILD = textwrap.dedent(
    """
    import os, signal, sys, time
    import numpy as np
    import lasalle

    # Python's own Ctrl-C handler, whatever the parent left: a process started in the
    # background by a non-interactive shell inherits SIGINT ignored
    signal.signal(signal.SIGINT, signal.default_int_handler)

    def tasks():
        return len(os.listdir("/proc/self/task"))

    m = lasalle.Model("kepler")
    y0 = [1.0, 0, 0, 0, 1.2, 0]
    base = tasks()
    for what in ("solve", "solve_many"):
        print("ready", flush=True)
        try:
            if what == "solve":
                # 10⁹ RK4 steps: tens of seconds
                m.solve(y0, (0, 1e5), "rk4", dt=1e-4)
            else:
                m.solve_many(np.tile(y0, (64, 1)), (0, 1e4), "dopri5", rtol=1e-13, atol=1e-13, threads=2)
            print("finished", flush=True)
        except KeyboardInterrupt:
            print("KeyboardInterrupt", flush=True)
        # the ensemble's pool winds down; then the process has the threads it started with
        for _ in range(100):
            if tasks() <= base:
                break
            time.sleep(0.02)
        print("tasks", tasks() - base, flush=True)
    # still usable afterwards
    print("after", m.solve(y0, (0, 1), "rk4", dt=1e-3).success, flush=True)
    """
)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="counts threads in /proc")
def test_ctrl_c_interrupts_solve_and_solve_many():
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        for what in ("solve", "solve_many"):
            assert child.stdout.readline().strip() == "ready", child.stderr.read()
            time.sleep(1.0)  # well into the run
            sent = time.monotonic()
            child.send_signal(signal.SIGINT)
            line = child.stdout.readline().strip()
            latency = time.monotonic() - sent
            assert line == "KeyboardInterrupt", (what, line, child.stderr.read())
            # a fraction of a second on an idle machine; generous on a shared one
            assert latency < 2.0, (what, latency)
            print(f"{what}: KeyboardInterrupt {latency * 1e3:.0f} ms after SIGINT")
            assert child.stdout.readline().strip() == "tasks 0", what
        assert child.stdout.readline().strip() == "after True"
        assert child.wait(timeout=30) == 0, child.stderr.read()
    finally:
        if child.poll() is None:
            os.kill(child.pid, signal.SIGKILL)
