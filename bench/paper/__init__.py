"""Reproduce the seed paper's experiments: ``python -m bench.paper --quick|--full|--smoke``.

One module per experiment (see :data:`bench.paper.__main__.EXPERIMENTS`); each writes
``<name>.json`` and PNGs into the output folder, and :mod:`bench.paper.report` turns them into
``docs/RESULTS.md`` with the paper's numbers alongside.
"""
