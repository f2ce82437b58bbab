"""Same records before and after a change: run a fixed set of episodes and compare with a reference.

A refactoring must not change what a user gets. This runs every offline method on the first episodes of
several splits under ``ideal`` and ``realistic`` (the matrix below), on a dataset built from scratch by the
code under test, and writes one canonical file: the dataset's file digests and every episode record
(timing removed, sorted). ``compare`` says which records differ, field by field.

    python scripts/compare_records.py run --out /tmp/after          # the code importable now
    python scripts/compare_records.py compare docs/data/records/reference.json.gz /tmp/after/records.json.gz

``docs/data/records/reference.json.gz`` is the reference: the records of the code before the architecture
rework. Replace it only with a change that means to change behaviour, and say so in the commit.
VLFM's reference records from that run are the GT detector's, under that method's current name
(``vlfm_gt``, ``protocol_vlfm_gt``); the learned detector's (``vlfm``, ``protocol_vlfm``) come from a
``run --methods vlfm,protocol_vlfm --jobs 1`` of the code that made it VLFM's default.

Records are exact on one machine and install: the same commit can give other image-method paths and PPO
weights elsewhere (CPU rendering and torch's kernels depend on the CPU and the library builds). Where a
run differs from the reference, run the code before the change on the same machine (a ``git worktree``)
and compare the two runs. The ``busy_val`` cells are newer than the reference (``--splits busy_val``
runs only them).

``--quick`` runs one episode per cell (a smoke check). The PPO checkpoint is trained here, seeded, so
training is compared too (its weights' digest is in the file). Images are 160x120 to keep the run short;
the code paths are those of any resolution. Fetch has its own dataset build (minutes) and is left out.
"""

from __future__ import annotations

import argparse
import gzip
import hashlib
import json
import os
import subprocess
import sys
import time
import zipfile
from pathlib import Path

from biovln_ms.io_utils import atomic_write_bytes
from biovln_ms.measured import write_table

SINGLE_GOAL = ("random", "oracle", "zone3_oracle", "frontier", "vlfm", "vlfm_gt", "ppo")
SINGLE_GOAL_SPLITS = ("ms_val", "ms_test", "two_room", "lsat_target", "hard_val", "molbio_val")
PROTOCOL = ("protocol_oracle", "protocol_frontier", "protocol_vlfm", "protocol_vlfm_gt", "protocol_language")
PROTOCOL_SPLITS = ("protocol_val",)
#: the busy lab's cells: its crowds walk in every step of these methods' episodes
BUSY = ("random", "oracle", "frontier", "vlfm_gt", "ppo")
BUSY_SPLITS = ("busy_val",)
#: (methods, splits) groups: every method of a group runs on every split of it, under each preset
MATRIX = ((SINGLE_GOAL, SINGLE_GOAL_SPLITS), (PROTOCOL, PROTOCOL_SPLITS), (BUSY, BUSY_SPLITS))
PRESETS = ("ideal", "realistic")
EPISODES = 2
CAMERA = (160, 120)
PPO_STEPS = 1024
#: record fields that measure the machine, not the behaviour
VOLATILE = ("wall_time_s",)

_RUNNER = """
import json, sys
from biovln_ms.eval.harness import EvalConfig, evaluate
for cell in json.loads(sys.argv[1]):
    evaluate(EvalConfig(**cell), progress=False, echo=lambda *_: None)
"""


def _cells(
    out: Path,
    episodes: int,
    checkpoint: Path,
    methods: set[str] | None = None,
    splits: set[str] | None = None,
) -> list[dict]:
    """The matrix's runs (only ``methods``' and ``splits``' when given)."""
    cells = []
    for noise in PRESETS:
        for group, group_splits in MATRIX:
            for method in group:
                kwargs = {"checkpoint": str(checkpoint)} if method == "ppo" else {}
                for split in group_splits:
                    cells.append(dict(method=method, split=split, noise=noise, method_kwargs=kwargs))
    cells = [
        c
        for c in cells
        if (methods is None or c["method"] in methods) and (splits is None or c["split"] in splits)
    ]
    for c in cells:
        c.update(out=str(out / "results"), max_episodes=episodes, camera=list(CAMERA), workers=1)
    return cells


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


#: digests of other files kept in dataset files: the catalog file's (which data-only catalog fields such as
#: map colours change) and the scene files' (which hold it); the files' own content is compared instead
DERIVED_KEYS = ("catalog_sha256", "sha256")


def _strip(obj):
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if k not in DERIVED_KEYS}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


def _content_digest(path: Path) -> str:
    """A JSON file's content without :data:`DERIVED_KEYS`; any other file's bytes."""
    if path.suffix != ".json":
        return _digest(path)
    canonical = json.dumps(_strip(json.loads(path.read_text())), sort_keys=True)
    return hashlib.sha256(canonical.encode()).hexdigest()


def _sh(args: list[str], env: dict) -> None:
    print("$", " ".join(args), flush=True)
    subprocess.run(args, env=env, check=True)


def run(
    out: Path, quick: bool, jobs: int, methods: set[str] | None = None, splits: set[str] | None = None
) -> Path:
    """Build the dataset, train the PPO checkpoint, run the matrix (``methods``' and ``splits``' cells only
    when given); write ``out/records.json.gz``."""
    out.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "BIOVLN_DATA_DIR": str(out / "dataset")}
    py = sys.executable
    t0 = time.time()
    _sh([py, "-m", "biovln_ms.cli", "dataset", "stats"], env)  # builds it on first use
    ckpt_dir = out / "ppo"
    if not (ckpt_dir / "model.zip").exists():
        _sh(
            [
                py,
                "-m",
                "biovln_ms.cli",
                "train",
                "ppo",
                "--timesteps",
                str(PPO_STEPS),
                "--n-envs",
                "1",
                "--eval-split",
                "",
                "--seed",
                "0",
                "--out",
                str(ckpt_dir),
            ],
            env,
        )
    cells = _cells(out, 1 if quick else EPISODES, ckpt_dir / "model.zip", methods, splits)
    groups = [cells[i::jobs] for i in range(jobs)]  # one process per job, each running its cells in turn
    procs = [subprocess.Popen([py, "-c", _RUNNER, json.dumps(g)], env=env) for g in groups if g]
    try:
        codes = [p.wait() for p in procs]  # every runner to its end, also after one failed
    finally:
        for p in procs:  # ^C or an error here: no runner left running on its own
            if p.poll() is None:
                p.terminate()
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
    if any(codes):
        raise SystemExit("a runner failed (its traceback is above)")
    result = collect(out, ckpt_dir / "model.zip")
    path = out / "records.json.gz"
    text = json.dumps(result, sort_keys=True, separators=(",", ":"))
    atomic_write_bytes(path, gzip.compress(text.encode(), mtime=0))  # the same records, the same bytes
    n = sum(len(v) for v in result["records"].values())
    print(f"{n} records in {len(result['records'])} runs, {time.time() - t0:.0f} s -> {path}")
    return path


def collect(out: Path, checkpoint: Path) -> dict:
    """The canonical content: dataset file digests, the checkpoint's, and the records by run folder."""
    data = out / "dataset"
    dataset = {
        str(p.relative_to(data)): _content_digest(p)
        for p in sorted(data.rglob("*"))
        if p.is_file() and p.suffix in (".json", ".gz", ".jsonl")
    }
    records = {}
    for f in sorted((out / "results").rglob("episodes.jsonl")):
        rows = [json.loads(line) for line in f.read_text().splitlines() if line.strip()]
        for r in rows:
            for k in VOLATILE:
                r.pop(k, None)
        rows.sort(key=lambda r: (r.get("scene_id", ""), r.get("episode_id", "")))
        records[str(f.parent.relative_to(out / "results"))] = rows
    return {"dataset": dataset, "checkpoint": _weights_digest(checkpoint), "records": records}


def _weights_digest(checkpoint: Path) -> str:
    """The SB3 checkpoint's tensors (policy, optimizer, variables); its ``data`` member holds the run's
    folder and clock, which differ between any two runs."""
    h = hashlib.sha256()
    with zipfile.ZipFile(checkpoint) as z:
        for name in sorted(n for n in z.namelist() if n.endswith(".pth")):
            h.update(name.encode() + z.read(name))
    return h.hexdigest()


def _load(path: Path) -> dict:
    with gzip.open(path, "rt") if path.suffix == ".gz" else open(path) as f:
        return json.load(f)


def run_differences(x: dict, y: dict) -> dict[str, list[tuple[str, str]]]:
    """Per run (method, split, preset) of either file: what differs, as (what, the line that says it):
    missing from a file, the episode count, an episode's field (``what`` the field's name); an empty list
    where the run is identical."""
    out = {}
    for run in sorted(set(x["records"]) | set(y["records"])):
        ra, rb = x["records"].get(run), y["records"].get(run)
        if ra is None or rb is None:
            where = f"only in {'the second' if ra is None else 'the first'}"
            out[run] = [(where, f"{run}: {where}")]
            continue
        found = [("episode count", f"{run}: {len(ra)} != {len(rb)} records")] if len(ra) != len(rb) else []
        for ea, eb in zip(ra, rb):
            for k in sorted(set(ea) | set(eb)):
                if ea.get(k) != eb.get(k):
                    episode = f"{ea.get('scene_id')}/{ea.get('episode_id')}"
                    found.append((k, f"{run} {episode} field '{k}' differs"))
        out[run] = found
    return out


def compare(a: Path, b: Path, limit: int = 20, data_out: Path | None = None) -> int:
    """Print the differences between two record files; the number of differing items. ``data_out``: also
    write a table of every run (its records, what differs) for the docs."""
    x, y = _load(a), _load(b)
    files = sorted(set(x["dataset"]) | set(y["dataset"]))
    differing = [name for name in files if x["dataset"].get(name) != y["dataset"].get(name)]
    diffs = [f"dataset file {f}: {x['dataset'].get(f)} != {y['dataset'].get(f)}" for f in differing]
    if x["checkpoint"] != y["checkpoint"]:
        diffs.append("ppo checkpoint differs")
    by_run = run_differences(x, y)
    for found in by_run.values():
        diffs += [line for _, line in found]
    for d in diffs[:limit]:
        print(d)
    n = sum(len(v) for v in x["records"].values())
    print(
        f"{len(diffs)} differences over {n} records and {len(x['dataset'])} dataset files"
        + (f" (first {limit} shown)" if len(diffs) > limit else "")
    )
    if data_out is not None:
        _table(x, y, by_run, (len(files) - len(differing), len(files)), a, b, data_out)
    return len(diffs)


def _table(x: dict, y: dict, by_run: dict, files: tuple[int, int], a: Path, b: Path, path: Path) -> None:
    """Per run: its episodes in each file and what differs (:func:`run_differences`, each named once);
    ``files``: (identical dataset files, all of them)."""
    rows = []
    for run, found in by_run.items():
        what = ", ".join(dict.fromkeys(w for w, _ in found)) or "identical"
        rows.append([run, len(x["records"].get(run, [])), len(y["records"].get(run, [])), what])
    same = sum(not found for found in by_run.values())
    write_table(
        path,
        "Records of a fixed set of episodes, two runs compared",
        ["run", f"episodes ({a.name})", f"episodes ({b.name})", "what differs"],
        rows,
        [
            f"{same} of {len(rows)} runs identical; dataset files identical: {files[0]} of {files[1]}; "
            f"PPO checkpoint {'identical' if x['checkpoint'] == y['checkpoint'] else 'different'}.",
            f"Compared: {a.name} (first) and {b.name} (second).",
        ],
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run the matrix with the code importable now")
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--quick", action="store_true", help="one episode per cell")
    r.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="runner processes")
    r.add_argument(
        "--methods",
        help="comma-separated: run only these methods' cells (compare: the others "
        "show as 'only in the first')",
    )
    r.add_argument(
        "--splits",
        help="comma-separated: run only these splits' cells (compare: others show as 'only in the first')",
    )
    c = sub.add_parser("compare", help="compare two records files")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    c.add_argument("--data-out", type=Path, help="also write a table of every run here (docs/data/records/)")
    args = p.parse_args()
    if args.cmd == "run":

        def chosen(flag: str, given: str | None, known: list[str]) -> set[str] | None:
            names = set(given.split(",")) if given else None
            if names and names - set(known):
                p.error(
                    f"{flag}: unknown {', '.join(sorted(names - set(known)))}; use some of {', '.join(known)}"
                )
            return names

        methods = chosen("--methods", args.methods, list(dict.fromkeys(m for g, _ in MATRIX for m in g)))
        splits = chosen("--splits", args.splits, list(dict.fromkeys(x for _, g in MATRIX for x in g)))
        run(args.out, args.quick, args.jobs, methods, splits)
    else:
        sys.exit(1 if compare(args.a, args.b, data_out=args.data_out) else 0)


if __name__ == "__main__":
    main()
