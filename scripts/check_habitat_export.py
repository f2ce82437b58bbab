"""Check a `biovln-ms dataset export habitat` folder against habitat-lab itself.

Run it with a Python that has habitat-lab installed (not a dependency of biovln-ms), for example a
separate venv: ``python -m venv /tmp/hl-venv && /tmp/hl-venv/bin/pip install habitat-lab``, then

    /tmp/hl-venv/bin/python scripts/check_habitat_export.py OUT [--split S ...]

With habitat-sim installed too, ``import habitat`` works and every split is loaded with habitat-lab's own
``ObjectNavDatasetV1.from_json``. Without it (every habitat-lab release on the package index imports
habitat-sim's ``magnum`` from ``import habitat``) the script reads the field lists of habitat-lab's attrs
classes (Episode, NavigationEpisode, ObjectGoalNavEpisode, NavigationGoal, ObjectGoal,
ObjectViewLocation, AgentState) from the installed source and checks each episode and goal as
``from_json`` builds them: known keys only, required ones not null. Either way it then checks what
habitat-sim will open: each episode's scene instance, its stage and overhead configs and assets, and the
semantic descriptor that holds every goal's integer ``object_id``. Prints one line per split and exits 1
on the first problem.
"""

from __future__ import annotations

import argparse
import ast
import gzip
import importlib.util
import json
import os
import sys
from pathlib import Path

CLASSES = {  # habitat-lab module (relative to the package) -> the classes it defines that we need
    "core/dataset.py": ("BaseEpisode", "Episode"),
    "core/simulator.py": ("AgentState",),
    "tasks/nav/nav.py": ("NavigationGoal", "NavigationEpisode"),
    "tasks/nav/object_nav_task.py": ("ObjectGoalNavEpisode", "ObjectViewLocation", "ObjectGoal"),
}


class ExportError(Exception):
    """One line: what in the export does not load, and where."""


def _rule(stmt: ast.AnnAssign) -> str:
    """``"given"``: no default, the key must be there (it may be null if the type is Optional);
    ``"not_null"``: the ``attr.ib`` has the ``not_none_validator`` and a None default, so the key must be
    there and not null; ``"not_null_if_given"``: the validator and a real default; ``""``: optional."""
    if stmt.value is None:
        return "given"
    if isinstance(stmt.value, ast.Call):
        kw = {k.arg: ast.unparse(k.value) for k in stmt.value.keywords}
        if "not_none" in kw.get("validator", ""):
            return "not_null" if kw.get("default", "None") == "None" else "not_null_if_given"
    return ""


Schema = tuple[set[str], set[str], set[str], set[str]]  # fields, must be given, not null, not null if given


def habitat_schema(package: Path) -> dict[str, Schema]:
    """``{class: (fields, given, not null, not null if given)}`` of the attrs classes, inherited fields
    included."""
    own, bases = {}, {}
    for rel, names in CLASSES.items():
        tree = ast.parse((package / rel).read_text())
        for node in tree.body:
            if isinstance(node, ast.ClassDef) and node.name in names:
                stmts = [
                    s for s in node.body if isinstance(s, ast.AnnAssign) and isinstance(s.target, ast.Name)
                ]
                fields = {s.target.id: _rule(s) for s in stmts if not s.target.id.startswith("_")}
                own[node.name] = fields
                bases[node.name] = [b.id for b in node.bases if isinstance(b, ast.Name)]
    missing = {n for names in CLASSES.values() for n in names} - own.keys()
    if missing:
        raise ExportError(f"habitat-lab source at {package} has no class {', '.join(sorted(missing))}")

    def resolve(name: str) -> dict[str, str]:
        out = {}
        for base in bases[name]:
            if base in own:
                out.update(resolve(base))
        return {**out, **own[name]}

    return {
        n: (
            set(f),
            *({k for k, r in f.items() if r == rule} for rule in ("given", "not_null", "not_null_if_given")),
        )
        for n in own
        for f in [resolve(n)]
    }


def _check_keys(obj: dict, schema: Schema, where: str) -> None:
    fields, given, not_null, not_null_if_given = schema
    extra = set(obj) - fields
    if extra:
        raise ExportError(f"{where}: {sorted(extra)} are not fields of habitat-lab's class")
    missing = sorted(given - set(obj))
    null = sorted(k for k in not_null | (not_null_if_given & set(obj)) if obj.get(k) is None)
    if missing or null:
        raise ExportError(f"{where}: required {missing + null} missing or null")


def check_with_source(data: dict, package: Path, path: Path) -> None:
    """``from_json``'s checks and constructions, with the classes' fields read from ``package``."""
    schema = habitat_schema(package)
    task, scene = data["category_to_task_category_id"], data["category_to_scene_annotation_category_id"]
    if set(task) != set(scene):
        raise ExportError(f"{path}: category_to_task_category_id and ..._scene_annotation_... differ in keys")
    for key, goals in data["goals_by_category"].items():
        for i, g in enumerate(goals):
            where = f"{path}: goals_by_category[{key!r}][{i}]"
            _check_keys(g, schema["ObjectGoal"], where)
            for j, v in enumerate(g.get("view_points") or []):
                _check_keys(v, schema["ObjectViewLocation"], f"{where}.view_points[{j}]")
                _check_keys(v["agent_state"], schema["AgentState"], f"{where}.view_points[{j}].agent_state")
    for i, ep in enumerate(data["episodes"]):
        _check_keys(ep, schema["ObjectGoalNavEpisode"], f"{path}: episodes[{i}]")


def check_with_habitat(path: Path, scenes_dir: Path) -> None:
    """Load with habitat-lab's own ObjectNavDatasetV1 (needs habitat-sim for ``import habitat``)."""
    from habitat.datasets.object_nav.object_nav_dataset import ObjectNavDatasetV1

    ds = ObjectNavDatasetV1()
    ds.from_json(gzip.decompress(path.read_bytes()).decode(), scenes_dir=str(scenes_dir))
    if not ds.episodes or any(not ep.goals for ep in ds.episodes):
        raise ExportError(f"{path}: habitat-lab loaded no episodes or an episode without goals")


def _ssd_ids(path: Path) -> dict[int, str]:
    lines = path.read_text().splitlines()
    if not lines or lines[0] != "HM3D Semantic Annotations":
        raise ExportError(f"{path}: not an HM3D-format semantic descriptor (first line)")
    return {int(line.split(",", 1)[0]): line.split('"')[1] for line in lines[1:] if line}


def check_scene_files(data: dict, scenes_dir: Path, path: Path) -> None:
    """What habitat-sim opens for each episode: scene instance, stage and object configs, their assets,
    and every goal's object_id as an instance of its category in the semantic descriptor."""
    config = json.loads((scenes_dir / "biovln.scene_dataset_config.json").read_text())
    ssds = config["semantic_scene_descriptor_instances"]
    for ep in data["episodes"]:
        instance_path = scenes_dir / ep["scene_id"]
        if not instance_path.is_file():
            raise ExportError(f"{path}: episode {ep['episode_id']}: no scene instance {instance_path}")
        instance = json.loads(instance_path.read_text())
        stage = json.loads((scenes_dir / instance["stage_instance"]["template_name"]).read_text())
        objects = [
            json.loads((scenes_dir / o["template_name"]).read_text()) for o in instance["object_instances"]
        ]
        for asset in [stage["render_asset"], stage["semantic_asset"], *(o["render_asset"] for o in objects)]:
            if (scenes_dir / asset).read_bytes()[:4] != b"glTF":
                raise ExportError(f"{scenes_dir / asset}: not a GLB")
        ids = _ssd_ids(scenes_dir / ssds[instance["semantic_scene_instance"]])
        for g in data["goals_by_category"][f"{ep['scene_id']}_{ep['object_category']}"]:
            if not isinstance(g["object_id"], int) or ids.get(g["object_id"]) != g["object_category"]:
                raise ExportError(
                    f"{path}: goal {g['object_name']}: object_id {g['object_id']!r} is not a "
                    f"'{g['object_category']}' instance of the semantic descriptor"
                )


def check(out: Path, splits: list[str] | None = None) -> list[str]:
    """Check every (or each named) split under ``out``; returns one summary line per split."""
    spec = importlib.util.find_spec("habitat")
    if spec is None or spec.origin is None:
        raise ExportError("habitat-lab is not installed in this Python (pip install habitat-lab)")
    package = Path(spec.origin).parent
    try:
        import habitat  # noqa: F401  (needs habitat-sim)

        mode = "habitat-lab ObjectNavDatasetV1.from_json"
    except ImportError:
        mode = f"habitat-lab source fields ({package})"
    scenes_dir = out / "scenes"
    names = splits or sorted(p.name for p in (out / "objectnav").iterdir() if p.is_dir())
    lines = []
    for split in names:
        path = out / "objectnav" / split / f"{split}.json.gz"
        data = json.loads(gzip.decompress(path.read_bytes()))
        if mode.startswith("habitat-lab Object"):
            check_with_habitat(path, scenes_dir)
        else:
            check_with_source(data, package, path)
        check_scene_files(data, scenes_dir, path)
        goals = sum(len(v) for v in data["goals_by_category"].values())
        lines.append(f"{split}: {len(data['episodes'])} episodes, {goals} goals: ok ({mode})")
    return lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="the folder `biovln-ms dataset export habitat -o` wrote")
    ap.add_argument("--split", action="append", help="a split to check (default: all)")
    args = ap.parse_args()
    try:
        for line in check(args.out, args.split):
            print(line)
    except (ExportError, OSError, KeyError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    os.environ.setdefault("HABITAT_SIM_LOG", "quiet")
    sys.exit(main())
