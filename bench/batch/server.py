"""Imported first by a pool's fork server (``executor.start_server``): it ends with its caller.

The server is a child of the process whose pools it serves. It leaves its select loop
when the caller's end of its "alive" pipe closes, but only once its imports (``preload``:
seconds) are done; so, first of all, Linux's ``PR_SET_PDEATHSIG`` has it killed the
moment the caller ends, however. Its workers, forked from it, set their own on it
(``executor._die_with_parent``): a killed caller takes the server, and the server its
workers. Elsewhere (no ``prctl``) the workers' watching thread is the fallback.
Standard library only, so that it runs within milliseconds of the server's start.

A pool's jobs never render, so MuJoCo is told there is no OpenGL backend to load
(``MUJOCO_GL=disable``, unless the caller chose one): its import then skips glfw's,
about 60 ms of the ~1.4 s the server imports before a sweep's first worker can start
(``slopewalk benchmark sweep``'s ``worker_start_s``, 2 cores).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal

PR_SET_PDEATHSIG = 1  # linux/prctl.h

with contextlib.suppress(Exception):  # not Linux, or no libc
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)

os.environ.setdefault("MUJOCO_GL", "disable")  # before the preload imports MuJoCo
