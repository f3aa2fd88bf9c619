"""``stackx bench``: every chosen solver over scenes and a range of its cost knob, measured and compared.

- ``case``: the ``bench:`` section of a config (criteria, knob values, settings, a lab claim to measure);
- ``plan``: which solver runs with which parameters on a case;
- ``sweep``: the batched runs of a case, each measured and judged (``stackx.bench.criteria``);
- ``timing``: microseconds per step, measured apart (what the bench measures beyond a run's own measures,
  and the every-step error against the reference solver, come from the case's model);
- ``claims``: the lab's claims (percent 1.0 oscillates, slop 0 jitters), measured;
- ``compare``: stability matrix, Pareto fronts and equal-cost winners;
- ``report``: ``bench.json`` and ``report.html``; ``plots``: its PNGs; ``tables``: the terminal tables;
- ``command``: the command itself, from loading the cases to writing the folder.

Only ``stackx bench`` imports the rest of this package; ``case`` stays light (pydantic) because configs use it.
"""
