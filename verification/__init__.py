"""Verification studies. Each module has ``main(fast: bool = False, outdir=None)`` that writes its
tables (markdown) and figures into ``outdir`` (default ``verification/out``) and returns its
numbers; ``--fast`` is the quick version the test-suite runs. ``make verify`` runs them all
(``verification/run_all.py``). The studies live in the source tree, not in the installed
packages."""
