"""Fuzzing: a few hundred seeded hostile configs (see ``fuzzgen``), each run through ``stackx run``: exit 0, 1 or
2, never a traceback, a located line on exit 2 with nothing written, a complete folder on exit 0. The 10,000-case
run is ``python3 -m benchmarks.fuzz_configs``."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from tests.conftest import Shown

from .fuzzgen import attempt, make

CASES = 300


def test_hostile_configs_keep_the_contract(tmp_path: Path, shown: Shown) -> None:
    failures, kinds, codes = [], Counter(), Counter()
    for seed in range(CASES):
        case = make(seed)
        folder = tmp_path / str(seed)
        folder.mkdir()
        code, problems = attempt(case, folder)
        codes[code] += 1
        kinds[case.how.split(" ")[0]] += 1
        if problems:
            failures.append(f"seed {seed} ({case.base}: {case.how}): {'; '.join(problems)}")
    shown(f"{CASES} hostile configs: {len(failures)} broke the contract; exit codes {dict(sorted(codes.items()))}")
    assert not failures, "\n".join(failures[:20])
    assert len(kinds) >= 8, kinds  # the mutations are varied
    assert codes[0] >= CASES // 20 and codes[2] >= CASES // 2, codes  # most are refused, some still run
