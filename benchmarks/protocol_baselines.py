"""Lab-protocol baselines: a stratified subset of the protocol splits, and why the language
agents' episodes fail.

``subset`` copies a dataset (default: the default dataset) to ``--out`` with ``protocol_val`` and
``protocol_test`` cut to every ``--stride``-th episode of each scene (the records copied verbatim, the
manifest's counts and hashes updated): the same episodes as the full splits, spread evenly over every scene
and template, for runs that cannot afford the full 160. ``biovln-ms report`` given the default dataset marks
such a run ``partial (n/160)``.

``failures`` reads the protocol runs under a results folder (every method but the oracle) and classifies
each failed episode by its first goal not reached: ``parse`` (the language agent's parsed targets differ
from the episode's (category, relation) list), ``out of budget``, ``unresolved`` (the language agent stopped
without having resolved the target on its map), ``other instance`` (it went to an instance of the category
other than the meant one: the instance nearest the centroid the language agent resolved, for the other
methods the instance nearest where it stopped), ``far`` (it stopped more than ``FAR`` m from every instance
of the category), ``side`` (the meant instance, but it stood more than 45 degrees round from the
operational face, seen from the instrument's centre) or ``front`` (the meant instance and its face side,
yet outside r).

    python benchmarks/protocol_baselines.py subset --out /tmp/protosub/ds --stride 5
    python benchmarks/protocol_baselines.py failures /tmp/protobench/results --dataset /tmp/protosub/ds
"""

from __future__ import annotations

import argparse
import gzip
import hashlib
import io
import json
import math
import shutil
from collections import Counter
from pathlib import Path

import numpy as np

from biovln_ms.splits import dataset_root
from biovln_ms.episodes.dataset import EpisodeDataset
from biovln_ms.io_utils import atomic_write_bytes, atomic_write_text

SPLITS = ("protocol_val", "protocol_test")
CAUSES = ("parse", "out of budget", "unresolved", "far", "other instance", "side", "front")
FAR = 2.0  # m: a stop this far from every instance of the category is at none of them
SIDE_DEG = 45.0  # a stop further round the instrument than this from its face is on another side


def write_subset(source: Path, out: Path, stride: int) -> dict[str, int]:
    """Copy the dataset ``source`` to ``out`` with the protocol splits cut to every ``stride``-th episode of
    each scene; returns the episodes kept per split."""
    if out.exists():
        shutil.rmtree(out)
    shutil.copytree(source, out)
    manifest = json.loads((out / "manifest.json").read_text())
    kept = {}
    for split in SPLITS:
        info = manifest["splits"][split]
        for entry in info["files"].values():
            path = out / entry["file"]
            with gzip.open(path) as f:
                episodes = json.load(f)["episodes"][::stride]
            buf = io.BytesIO()
            with gzip.GzipFile(fileobj=buf, mode="wb", mtime=0) as g:  # mtime 0: the same bytes every time
                g.write(json.dumps({"episodes": episodes}).encode())
            atomic_write_bytes(path, buf.getvalue())
            entry.update(episodes=len(episodes), sha256=hashlib.sha256(buf.getvalue()).hexdigest())
        info["episodes"] = kept[split] = sum(e["episodes"] for e in info["files"].values())
    atomic_write_text(out / "manifest.json", json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    return kept


def classify(rec: dict, episode: dict, spec) -> tuple[int, str]:
    """(first goal not reached, its cause) of a failed protocol record."""
    stats = rec.get("policy_stats", {})
    relations = episode["protocol"]["relations"]
    s = next(i for i, v in enumerate(rec["subgoal_status"]) if v != 1)
    want = [[g["object_category"], r] for g, r in zip(episode["goals"], relations)]
    if "targets" in stats and stats["targets"] != want:
        return s, "parse"
    if rec["out_of_budget"]:
        return s, "out of budget"
    end = rec["positions"][-1]
    if "resolved" in stats:
        at = stats["resolved"][s] if s < len(stats["resolved"]) else None
        if at is None:
            return s, "unresolved"
    else:
        at = end
    goal = episode["goals"][s]
    peers = [o for o in spec.objects() if o.category == goal["object_category"]]
    near = min(peers, key=lambda o: math.dist(o.position[:2], at))
    if math.dist(near.position[:2], end) > FAR:
        return s, "far"
    if near.id != goal["object_id"]:
        return s, "other instance"
    centre = np.array(near.position[:2])
    a, b = np.array(end) - centre, np.array(goal["eq1_goal"]) - centre
    cos = float(a @ b) / (float(np.linalg.norm(a) * np.linalg.norm(b)) or 1.0)
    return s, "side" if cos < math.cos(math.radians(SIDE_DEG)) else "front"


def failures(results: Path, ds: EpisodeDataset) -> list[str]:
    """Markdown: per protocol run and split, the failures by cause, for targets with and without a
    relation, and (language agent) how its parse and its relation targets fared."""
    out = []
    for path in sorted(results.glob("*@protocol/*/episodes.jsonl")):
        method, split = path.parent.parent.name.removesuffix("@protocol"), path.parent.name
        if method == "protocol_oracle":
            continue
        episodes = {(e["scene_id"], e["episode_id"]): e for e in ds.episodes(split)}
        recs = [json.loads(line) for line in path.open()]
        specs: dict = {}
        causes: Counter = Counter()
        parsed = relation_targets = relation_reached = first_leg = 0
        for rec in recs:
            ep = episodes[(rec["scene_id"], rec["episode_id"])]
            relations = ep["protocol"]["relations"]
            want = [[g["object_category"], r] for g, r in zip(ep["goals"], relations)]
            parsed += rec.get("policy_stats", {}).get("targets") == want
            status = rec["subgoal_status"][: len(relations)]
            tried = status.index(0) + 1 if 0 in status else len(status)  # up to the goal it ended on
            for r, st in zip(relations[:tried], status):
                relation_targets += r is not None
                relation_reached += r is not None and st == 1
            if not rec["success"]:
                spec = specs.setdefault(rec["scene_id"], ds.spec(rec["scene_id"]))
                s, cause = classify(rec, ep, spec)
                causes[(cause, relations[s] is not None)] += 1
                first_leg += s == 0
        fails = len(recs) - sum(r["success"] for r in recs)
        parse = f"targets parsed exactly in {parsed}; " if method == "protocol_language" else ""
        out += [
            f"**{method} on {split}** ({len(recs)} episodes, {fails} failed, {first_leg} of them at the "
            f"first goal; {parse}goals with a relation tried {relation_targets}, reached {relation_reached})",
            "",
            "| cause of the first goal missed | goal without a relation | with a relation |",
            "|---|---|---|",
            *(
                f"| {c} | {causes[(c, False)]} | {causes[(c, True)]} |"
                for c in CAUSES
                if causes[(c, False)] + causes[(c, True)]
            ),
            "",
        ]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    a = sub.add_parser("subset", help="write the stratified subset of the protocol splits")
    a.add_argument("--out", type=Path, required=True)
    a.add_argument("--stride", type=int, default=5)
    a.add_argument("--dataset", type=Path, default=None, help="source dataset (default: the default one)")
    b = sub.add_parser("failures", help="classify the failed protocol episodes")
    b.add_argument("results", type=Path)
    b.add_argument("--dataset", type=Path, default=None, help="the dataset the runs were made on")
    args = ap.parse_args()
    if args.command == "subset":
        kept = write_subset(dataset_root(args.dataset), args.out, args.stride)
        print(f"wrote {args.out}: " + ", ".join(f"{s} {n} episodes" for s, n in kept.items()))
    else:
        print("\n".join(failures(args.results, EpisodeDataset(dataset_root(args.dataset)))))


if __name__ == "__main__":
    main()
