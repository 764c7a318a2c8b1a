"""The compiled evaluation kernel: the whole analytic pipeline of ``plan.py`` in numba.

``tables`` turns a robot and a walk's timeline into flat numeric tables (the
gait as one cubic polynomial per piece of the walk, the DH chain's constants, the
sample list); ``sample`` is the per-sample pipeline (spline gait in closed form,
IK, FK, Newton-Euler, multibody ZMP, support polygon and margin, friction ratio,
joint power); ``run`` drives it over a plan's samples or over a GA population
(``prange``, one thread per individual).
``dynamics`` runs the same per-block stages on joint motion that is not a gait's (the
walk a servo reaches: torques and their linearisation), and ``servo`` the servo loop
through time and the compliance fixed point on them (the per-trial predictors of
``servo_loop`` and ``compliance``, whose numpy code stays as the reference), ``rocking``
the tipping predictor's step through time (``tipping.rocking``'s loop), ``whole_body``
the whole-body walk's mass matrix, stiffness and time loop (``planner/whole_body.py``'s).

Compiled code is cached (``cache=True``) in the user's cache directory, never in
the source tree, so the package works from a read-only install: unless the user
has set ``NUMBA_CACHE_DIR`` it is set here, before numba is first imported, to
``$XDG_CACHE_HOME/slopewalk/numba`` (``~/.cache/slopewalk/numba`` by default), or
to a per-user folder under the temp directory if that one cannot be written. Each
kernel module is cached under a key of its own source and its kernel imports'
(``cache``), so an edit recompiles only the modules that see it.

Compile time (issue 24; ``tools/compile_profile.py`` prints it per function): numba
compiles every ``@njit`` function a kernel function calls into an LLVM library of its
own, optimised and turned into machine code, then links that library into each
caller's and optimises and emits it again there, callee and all. A thin wrapper
around the big per-block stages (``dynamics._pass``, ``sample.evaluate_loaded``) or
a function in the middle of a deep chain (``servo._step``) so cost its callees'
LLVM work once more, 1-2 s each: such functions are ``inline="always"`` (numba's IR,
typed in each caller) and have no library of their own. The rest is numba's own
Python, ~1 ms per typed operation, in type inference and lowering alike.

The parallel kernels run on numba's OpenMP threading layer. GNU OpenMP's threads
spin after each parallel region before they sleep, and a GA calls the kernel once
per generation with a few ms of single-threaded Python (pymoo) in between: on a
2-core machine the spinning worker took a core from that Python and doubled the
driver's time per generation (measured 10.2 -> 5.7 ms, load ~4). So, unless the
user has set ``OMP_WAIT_POLICY``, it is set to ``passive`` here, before numba's
OpenMP pool starts (it starts at the first parallel call); waking a sleeping
worker costs microseconds per kernel call, which take milliseconds.
"""

from __future__ import annotations

import os
import sys

from slopewalk.planner.kernel.location import default_dir


def _set_cache_dir() -> None:
    if os.environ.get("NUMBA_CACHE_DIR") or "numba" in sys.modules:
        return  # the user's choice (or a numba already configured) wins
    os.environ["NUMBA_CACHE_DIR"] = str(default_dir())


_set_cache_dir()
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

from slopewalk.planner.kernel import cache  # noqa: E402  (numba, configured above)

cache.install()
