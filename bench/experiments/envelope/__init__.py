"""The stability envelope: the envelope file (``config``), one GA-plus-trials cell
(``cell``), the runner (``run``), its controllers table and benchmark.

The shipped envelope files live in ``bench/experiments/envelopes/``."""
