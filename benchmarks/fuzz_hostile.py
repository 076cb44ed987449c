"""Fuzz: the hostile-input corpus and N random mutations against the installed ``sizefx``.

    python benchmarks/fuzz_hostile.py [--cases 200] [--seed 0] [--workers 2] [--limit-s 60]
                                      [--bomb-rows 200000000] [--out DIR] [--json out.json] [--record]

Every case runs as a subprocess of the console script next to this Python (what a user runs),
two at a time; each child's peak RSS comes from ``os.wait4``. The corpus is
``tests/hostile_corpus.py`` (the same one ``tests/test_hostile.py`` runs in-process); the
mutations are drawn from ``--seed``: a value of a valid record replaced by NaN, inf, 1e300,
a tiny or a random number; a numeric option given a random value; a few bytes of a valid
record, levers, model or CSV file overwritten. Each run is judged by the same promises as the
tests (``hostile_corpus.broken_promises``): exit code, one stderr line naming the file, no
traceback, no output or ``*.tmp`` left, inputs unchanged, peak RSS under the ceiling, an exit
within ``--limit-s``.

Prints the command that produced the figures, how many cases were tried, refused cleanly and
run cleanly, and every failure: the case, the promise broken, the first stderr line. Exit code
1 when any case failed (so CI can run it), 0 otherwise. Nothing is timed as a benchmark: the
wall time is printed for planning only.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

TESTS = Path(__file__).resolve().parents[1] / "tests"
sys.path.insert(0, str(TESTS))
import hostile_corpus as hc  # noqa: E402  (tests/ holds the corpus and support.py)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit  # noqa: E402  (a sibling of this script)

#: Replacement values for a record mutation: the non-finite ones and the extremes of float64
#: first, then a random normal number at a random scale.
SPECIAL_VALUES = (np.nan, np.inf, -np.inf, 1e300, -1e300, 1e30, 5e-324, 0.0, -0.0)
#: Random option values: the non-finite spellings click accepts, and extremes.
SPECIAL_OPTION_VALUES = (
    "nan",
    "-nan",
    "inf",
    "-inf",
    "+Infinity",
    "1e308",
    "-1e308",
    "1e309",
    "5e-324",
    "0",
    "-0",
    "-1",
    "1" + "0" * 30,
    "-" + "9" * 25,
)


def _random_value(rng):
    if rng.random() < 0.5:
        return float(SPECIAL_VALUES[int(rng.integers(len(SPECIAL_VALUES)))])
    return float(rng.standard_normal() * 10.0 ** int(rng.integers(-30, 31)))


def _random_option_value(rng):
    if rng.random() < 0.6:
        return SPECIAL_OPTION_VALUES[int(rng.integers(len(SPECIAL_OPTION_VALUES)))]
    return repr(float(rng.standard_normal() * 10.0 ** int(rng.integers(-10, 12))))


def mutations(root: Path, n: int, seed: int) -> list:
    """``n`` random cases: a third value mutations, a third option values, a third byte flips."""
    rng = np.random.default_rng(seed)
    options = hc.numeric_options()
    cases = []
    for k in range(n):
        kind = k % 3
        if kind == 0:
            dataset = sorted(hc.MUTATION_TARGETS)[int(rng.integers(len(hc.MUTATION_TARGETS)))]
            row, col = int(rng.integers(0, 1000)), int(rng.integers(0, 3))
            value = _random_value(rng)
            command = ("inspect", "navigate")[int(rng.integers(2))]
            cases.append(
                hc.mutated_value_case(
                    root,
                    f"fuzz{k}-value-{dataset.replace('/', '-')}-{row}-{col}-{value!r}-{command}",
                    dataset,
                    row,
                    col,
                    value,
                    command,
                )
            )
        elif kind == 1:
            path, flag, _ = options[int(rng.integers(len(options)))]
            value = _random_option_value(rng)
            cases.append(hc.option_case(root, path, flag, value, f"fuzz{k}-option-{'-'.join(path)}{flag}-{value[:30]}"))
        else:
            what = ("rec", "levers", "model", "csv")[int(rng.integers(4))]
            cases.append(hc.byte_flip_case(root, f"fuzz{k}-bytes-{what}", rng, what))
    return cases


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=200, help="random mutations on top of the corpus")
    ap.add_argument("--seed", type=int, default=0, help="seed of the mutations")
    ap.add_argument("--workers", type=int, default=2, help="cases run at a time")
    ap.add_argument("--limit-s", type=float, default=60.0, help="seconds before a case counts as a hang")
    ap.add_argument("--bomb-rows", type=int, default=hc.BOMB_ROWS, help="rows of the gzip bomb (x3 float64)")
    ap.add_argument("--out", type=Path, help="keep the corpus and outputs here (default: a temporary folder)")
    add_output_options(ap)
    ap.add_argument("--no-corpus", action="store_true", help="only the random mutations")
    args = ap.parse_args(argv)
    if hc.console_script() is None:
        print("fuzz_hostile: no sizefx console script next to this Python; install sizefx first", file=sys.stderr)
        return 2
    root = args.out or Path(tempfile.mkdtemp(prefix="sizefx-fuzz-"))
    root.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    corpus = hc.write_corpus(root / "corpus", bomb_rows=args.bomb_rows)
    cases = [] if args.no_corpus else list(corpus)
    cases += mutations(root / "corpus", args.cases, args.seed)
    t_write = time.perf_counter() - t0

    done = [0]

    def progress(o):
        done[0] += 1
        if done[0] % 50 == 0:
            print(f"  {done[0]}/{len(cases)} run", file=sys.stderr, flush=True)

    t1 = time.perf_counter()
    outcomes = hc.run_cases(
        cases,
        root / "runs",
        workers=args.workers,
        subprocess_all=True,
        subprocess_limit_s=args.limit_s,
        progress=progress,
    )
    t_run = time.perf_counter() - t1

    skipped = [c for c in cases if c.skip]
    failures, refused, accepted = [], 0, 0
    for name, o in outcomes.items():
        broken = hc.broken_promises(o, limit_s=args.limit_s)
        if broken:
            first = o.stderr.strip().splitlines()[0][:200] if o.stderr.strip() else hc.tail(o.traceback or "")
            failures.append(
                {
                    "case": name,
                    "command": "sizefx " + " ".join(a[:80] for a in o.case.argv),
                    "exit_code": o.exit_code,
                    "broken": broken,
                    "stderr": first,
                    "peak_rss_mib": round(o.peak_rss_bytes / 2**20),
                }
            )
        elif o.exit_code == 2:
            refused += 1
        else:
            accepted += 1
    peak = max(outcomes.values(), key=lambda o: o.peak_rss_bytes)
    slowest = max(outcomes.values(), key=lambda o: o.seconds)

    cmd = "python benchmarks/fuzz_hostile.py " + " ".join(sys.argv[1:] if argv is None else argv)
    print(f"command: {cmd}")
    print(f"sizefx: {hc.console_script()}")
    print(
        f"corpus {len(corpus)} cases + {args.cases} mutations (seed {args.seed}); written in {t_write:.1f} s, "
        f"run in {t_run:.1f} s with {args.workers} workers"
    )
    print(
        f"tried {len(outcomes)}, refused cleanly {refused}, ran cleanly {accepted}, failed {len(failures)}, "
        f"skipped {len(skipped)}"
    )
    print(
        f"peak RSS {peak.peak_rss_bytes / 2**20:.0f} MiB ({peak.case.name}; ceiling "
        f"{hc.MEMORY_CEILING_BYTES / 2**30:.1f} GiB), slowest {slowest.seconds:.1f} s ({slowest.case.name})"
    )
    for c in skipped:
        print(f"skipped {c.name}: {c.skip}")
    if failures:
        print("failures (case | promise broken | first stderr line):")
    for f in sorted(failures, key=lambda f: f["case"]):
        for b in f["broken"]:
            print(f"  {f['case']} | {b[:200]} | {f['stderr']!r}")
    figures = {
        "tried": len(outcomes),
        "refused_cleanly": refused,
        "ran_cleanly": accepted,
        "failures": failures,
        "skipped": [c.name for c in skipped],
        "run_s": round(t_run, 1),
        "peak_rss_mib": round(peak.peak_rss_bytes / 2**20),
    }
    emit(figures, args, __file__, argv, threads=args.workers, show=False)
    if args.out is None:
        shutil.rmtree(root, ignore_errors=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
