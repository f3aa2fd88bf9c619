"""``stackx bench``: every chosen solver over scenes and a range of its cost knob, measured and compared.

- ``case``: the ``bench:`` section of a config (criteria, knob values, settings, a lab claim to measure);
- ``plan``: which solver runs with which parameters on a case;
- ``sweep``: the batched runs, the timings and the error against the exact solver;
- ``claims``: the lab's claims (percent 1.0 oscillates, slop 0 jitters), measured;
- ``compare``: stability matrix, Pareto fronts and equal-cost winners;
- ``report``: terminal tables, ``bench.json``, ``report.html`` and its plots.

This package is imported by ``stackx bench`` only; ``case`` stays light (pydantic) because configs use it.
"""
