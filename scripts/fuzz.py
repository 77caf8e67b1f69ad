"""Damaged datasets given to oftimg: how it answers each (issue 59).

    python scripts/fuzz.py [--cases 1000] [--seed 0] [--run-every 25] [--work DIR]

Small phantom datasets (meshes, label volumes) are each damaged in one seeded way
(oftimg.synthetic.damage) and given to `oftimg validate`, every --run-every-th to
`oftimg run` too. Prints the outcomes (exit status, by mutation) and every fault:
a crash, a hang, exception text or raw bytes on the terminal, more or less than one
error line, a changed input, anything left beside --out. Exits 1 if any.
"""

from __future__ import annotations

import argparse
import collections
import sys
import tempfile
import time

from oftimg.cli import main as oftimg_main
from oftimg.synthetic.damage import fuzz


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--run-every", type=int, default=25)
    parser.add_argument("--work", help="folder for the cases (default: a temporary one)")
    args = parser.parse_args()
    tick = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="oftimg-fuzz-", dir=args.work) as work:
        outcomes = fuzz(args.cases, work, oftimg_main, seed=args.seed, run_every=args.run_every)
    seconds = time.perf_counter() - tick
    by_mutation = collections.defaultdict(collections.Counter)
    for o in outcomes:
        by_mutation[f"{o.base}/{o.mutation.split(':')[0]}"][(o.command, o.exit_code)] += 1
    print(
        f"{args.cases} damaged datasets (seed {args.seed}), {len(outcomes)} commands, "
        f"{seconds:.0f} s"
    )
    print(f"{'base/mutation':28s} outcomes (command exit: count)")
    for name in sorted(by_mutation):
        counts = ", ".join(
            f"{cmd} {code}: {n}" for (cmd, code), n in sorted(by_mutation[name].items(), key=str)
        )
        print(f"{name:28s} {counts}")
    slowest = max(outcomes, key=lambda o: o.seconds)
    print(
        f"slowest: case {slowest.case} ({slowest.mutation}), {slowest.command}, "
        f"{slowest.seconds:.1f} s"
    )
    faults = [o for o in outcomes if o.faults]
    print(f"faults: {len(faults)}")
    for o in faults:
        print(
            f"  case {o.case} {o.base} {o.mutation} ({o.command}, exit {o.exit_code}): "
            f"{'; '.join(o.faults)} | {o.first_line}"
        )
    return 1 if faults else 0


if __name__ == "__main__":
    sys.exit(main())
