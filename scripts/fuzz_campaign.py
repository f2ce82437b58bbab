"""The long fuzz campaign: seeded inputs per target of ``tests/fuzz_targets.py`` (10,000 default),
with a progress bar, written as a Markdown table (tried / clear error / accepted correctly / other) and the
seeds of any "other" outcome. The table also goes to ``docs/data/fuzz_campaign.json`` (``--data-out``),
which the docs' Trust page renders; with ``--only`` the rows of the other targets already there are kept
(the file's provenance says which rows this run measured).

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
from biovln_ms.measured import docs_data_dir, load_table, write_table  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10_000, help="inputs per target")
    ap.add_argument("--only", nargs="*", default=None, help="targets (default: all)")
    ap.add_argument("-o", "--out", type=Path, default=Path("outputs/fuzz/campaign.md"))
    ap.add_argument("--data-out", type=Path, default=docs_data_dir() / "fuzz_campaign.json")
    args = ap.parse_args()
    unknown = sorted(set(args.only or ()) - set(TARGETS))
    if unknown:
        ap.error(f"unknown target(s) {', '.join(unknown)}; the targets are {', '.join(sorted(TARGETS))}")
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
    notes, provenance = lines[len(rows) + 3 :], None
    if args.only and args.data_out.exists():
        cells, notes, provenance = _merged(load_table(args.data_out), cells, notes)
    write_table(
        args.data_out,
        f"Fuzz campaign, {args.n:,} inputs per target",
        ["target", "input", "tried", "clear error", "accepted correctly", "other", "time"],
        cells,
        notes=notes,
        provenance=provenance,
    )
    return 1 if failures else 0


def _merged(old: dict, cells: list[list], notes: list[str]) -> tuple[list[list], list[str], str]:
    """The rows of an earlier table, those of this run's targets replaced in place and new ones after
    them; the notes of both; a provenance naming which command measured which rows."""
    ran = [c[0] for c in cells]
    new = {c[0]: c for c in cells}
    rows = [new.pop(r[0], r) for r in old["rows"]] + list(new.values())
    kept = [n for n in old.get("notes", []) if n != "No other outcome."]
    by = f"`{old['command']}` ({old.get('written', '?')})"
    earlier = (old.get("provenance") or f"measured by {by}").replace("by this command", f"by {by}")
    provenance = (
        f"The rows of {', '.join(ran)} were measured by this command; the others come from the file's "
        f"earlier runs: {earlier}"
    )
    return rows, (kept + notes if kept or notes != ["No other outcome."] else notes), provenance


if __name__ == "__main__":
    sys.exit(main())
