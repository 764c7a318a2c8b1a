"""Sweeps: the sweep file (``config``), its trials (``trials``) and the runner (``run``).

The shipped sweep files live in ``bench/experiments/sweeps/``."""
