"""The long fuzz campaign: seeded inputs per target of ``tests/fuzz_targets.py`` (10,000 default),
with a progress bar, written as a Markdown table (tried / clear error / accepted correctly / other) and the
seeds of any "other" outcome. The table also goes to ``docs/data/fuzz_campaign.json`` (``--data-out``),
which the docs' Trust page renders.

    python scripts/fuzz_campaign.py --n 10000 -o outputs/fuzz/campaign.md [--only spec_file ...]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fuzz_targets import TARGETS  # noqa: E402

from biovln_ms.io_utils import atomic_write_text  # noqa: E402
from biovln_ms.measured import docs_data_dir, write_table  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10_000, help="inputs per target")
    ap.add_argument("--only", nargs="*", default=None, help="targets (default: all)")
    ap.add_argument("-o", "--out", type=Path, default=Path("outputs/fuzz/campaign.md"))
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "fuzz_campaign.json")
    args = ap.parse_args()
    rows, cells, failures = [], [], {}
    for name in args.only or sorted(TARGETS):
        target = TARGETS[name]
        with tempfile.TemporaryDirectory() as tmp:
            state = target.setup(Path(tmp))
            counts: Counter = Counter()
            t0 = time.perf_counter()
            for seed in tqdm(range(args.n), desc=name, unit="input"):
                outcome = target.run(state, seed, Path(tmp))
                counts[outcome] += 1
                if outcome == "other":
                    failures.setdefault(name, []).append(seed)
        seconds = time.perf_counter() - t0
        rows.append(
            f"| `{name}` | {target.what} | {args.n:,} | {counts['clear']:,} | {counts['accepted']:,} | "
            f"{counts['other']:,} | {seconds:.0f} s |"
        )
        cells.append(
            [
                f"`{name}`",
                target.what,
                args.n,
                counts["clear"],
                counts["accepted"],
                counts["other"],
                f"{seconds:.0f} s",
            ]
        )
    lines = [
        "| target | input | tried | clear error | accepted correctly | other | time |",
        "|---|---|---|---|---|---|---|",
        *rows,
        "",
    ]
    lines += [f"- `{n}`: other outcomes at seeds {s[:20]}" for n, s in failures.items()] or [
        "No other outcome."
    ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out, "\n".join(lines) + "\n")
    print("\n".join(lines))
    write_table(
        args.data_out,
        f"Fuzz campaign, {args.n:,} inputs per target",
        ["target", "input", "tried", "clear error", "accepted correctly", "other", "time"],
        cells,
        notes=lines[len(rows) + 3 :],
    )
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
