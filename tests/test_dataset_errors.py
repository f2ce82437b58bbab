"""Every bad dataset gives one ``DatasetError`` line, and nothing outside its folder is read.

Each bad dataset is a valid small one (the held-out scene of seed 154, as ``held_out_dataset`` builds it)
with one edit. Where the edit changes a file, its SHA-256 in the manifest is rewritten too, as a careless
hand edit would, so the file gets past the hash check to the parser."""

from __future__ import annotations

import copy
import gzip
import hashlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import tracemalloc
import zlib
from pathlib import Path

import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

from biovln_ms.splits import FOUR_CATEGORIES
from biovln_ms.episodes import dataset
from biovln_ms.episodes.dataset import DatasetError, EpisodeDataset
from biovln_ms.episodes.writer import SplitPlan, gz_json, write_dataset
from biovln_ms.episodes.source import DatasetEpisodes
from biovln_ms.scene.generator import generate_scene

SCENE = generate_scene("single_room", 154, required_categories=FOUR_CATEGORIES)
EPISODES = "ms_val/content/lab_s154_v0.json.gz"  # ms_val's file, also listed by the view split
SCENE_FILE = "scenes/lab_s154_v0.json"
NAN = float("nan")


def _splits(n: int = 3) -> list[SplitPlan]:
    return [
        SplitPlan("ms_val", [(SCENE, n, False)]),
        SplitPlan("ms_val_view", [(SCENE, n, False)], view_of="ms_val"),
        SplitPlan("lsat_target", [], missing="not built"),
    ]


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Path:
    """A valid dataset: a split, a view of it and a split that is not built. Never edited."""
    root = tmp_path_factory.mktemp("base") / "ds"
    write_dataset(root, _splits(), progress=False)
    return root


@pytest.fixture
def root(base: Path, tmp_path: Path) -> Path:
    """A fresh copy of ``base`` to edit."""
    return Path(shutil.copytree(base, tmp_path / "ds"))


def _manifest(root: Path):
    return json.loads((root / "manifest.json").read_text())


def _save_manifest(root: Path, m) -> None:
    (root / "manifest.json").write_text(json.dumps(m, indent=1))


def _set_file(root: Path, rel: str, data: bytes) -> None:
    """Write ``data`` to ``rel`` and its SHA-256 into every manifest entry of that file."""
    (root / rel).write_bytes(data)
    m = _manifest(root)
    digest = hashlib.sha256(data).hexdigest()
    for entry in [*m["scenes"].values(), *(f for s in m["splits"].values() for f in s["files"].values())]:
        if entry["file"] == rel:
            entry["sha256"] = digest
    _save_manifest(root, m)


def _episodes_obj(root: Path) -> dict:
    return json.loads(gzip.decompress((root / EPISODES).read_bytes()))


def _load_all(root: Path) -> dict:
    """Everything the CLI and the env read: the manifest, every split's episodes and stats, every scene."""
    ds = EpisodeDataset(root)
    out = {}
    for split in ds.split_names():
        if split == "lsat_target" and not ds.manifest["splits"][split]["files"]:
            continue
        out[split] = list(ds.episodes(split))
        ds.stats(split)
    for scene in ds.manifest["scenes"]:
        ds.spec(scene)
    DatasetEpisodes("ms_val", root)
    return out


def _refused(root: Path, match: str, field: str | None = None) -> DatasetError:
    with pytest.raises(DatasetError, match=match) as e:
        _load_all(root)
    assert "\n" not in str(e.value)
    if field is not None:
        assert e.value.field == field, str(e.value)
    return e.value


# --- the valid dataset ------------------------------------------------------------------------------
def test_valid_dataset_loads_exactly_as_stored(base):
    eps = _load_all(base)
    stored = json.loads(gzip.decompress((base / EPISODES).read_bytes()))["episodes"]
    assert eps["ms_val"] == stored and eps["ms_val_view"] == stored and len(stored) == 3
    assert EpisodeDataset(base).manifest == json.loads((base / "manifest.json").read_text())


# --- manifests of the wrong shape or with missing keys -----------------------------------------------
def _edit(path: tuple, value=None, delete: bool = False):
    def edit(m):
        node = m
        for key in path[:-1]:
            node = node[key]
        if delete:
            del node[path[-1]]
        else:
            node[path[-1]] = value
        return m

    return edit


def _rename_scene_of_files(m):
    m["splits"]["ms_val"]["files"] = {"ghost": m["splits"]["ms_val"]["files"]["lab_s154_v0"]}
    m["splits"]["ms_val"]["scenes"] = ["ghost"]
    return m


FILE_ENTRY = ("splits", "ms_val", "files", "lab_s154_v0")
MANIFEST_FINDINGS = [  # (id, edit, message, field): each loaded without a DatasetError before
    ("a_list", lambda m: [m], "must be a JSON object, not list", None),
    ("a_string", lambda m: "manifest", "must be a JSON object, not str", None),
    ("splits_a_list", lambda m: {**m, "splits": list(m["splits"].values())}, "valid dictionary", "splits"),
    ("splits_a_string", _edit(("splits",), "ms_val"), "valid dictionary", "splits"),
    ("no_scenes_key", _edit(("scenes",), delete=True), "Field required", "scenes"),
    ("no_files_key", _edit(("splits", "ms_val", "files"), delete=True), "required", "splits.ms_val.files"),
    (
        "no_file_path",
        _edit((*FILE_ENTRY, "file"), delete=True),
        "required",
        "splits.ms_val.files.lab_s154_v0.file",
    ),
    ("file_entry_a_string", _edit(FILE_ENTRY, "x"), "valid dictionary", "splits.ms_val.files.lab_s154_v0"),
    ("radius_a_string", _edit(("agent_radius",), "0.2"), "valid number", "agent_radius"),
    ("radius_nan", _edit(("agent_radius",), NAN), "finite number", "agent_radius"),
    ("seed_huge_int", _edit(("scenes", "lab_s154_v0", "seed"), "HUGE"), "not valid JSON", None),
    (
        "scene_without_file",
        _edit(("splits", "ms_val", "scenes"), ["lab_s154_v0", "x"]),
        "no file",
        "splits.ms_val.files",
    ),
    (
        "file_of_unknown_scene",
        _rename_scene_of_files,
        "not in the manifest's scenes",
        "splits.ms_val.files.ghost",
    ),
    (
        "count_mismatch",
        _edit(("splits", "ms_val", "episodes"), 4),
        "its files hold 3",
        "splits.ms_val.episodes",
    ),
]


@pytest.mark.parametrize("name, edit, match, field", MANIFEST_FINDINGS, ids=[f[0] for f in MANIFEST_FINDINGS])
def test_malformed_manifest_is_one_dataset_error(root, name, edit, match, field):
    m = edit(_manifest(root))
    if name == "seed_huge_int":
        text = json.dumps(m).replace('"HUGE"', "9" * 5000)  # json's digit limit: a ValueError unless caught
        (root / "manifest.json").write_text(text)
    else:
        _save_manifest(root, m)
    err = _refused(root, match, field)
    assert err.source == str(root / "manifest.json")


def test_non_utf8_manifest(root):
    (root / "manifest.json").write_bytes(b"\xff" + (root / "manifest.json").read_bytes())
    _refused(root, "not UTF-8")


# --- episode files: not gzip, truncated, not JSON, missing fields, wrong types, non-finite numbers ---
def _gz_text(text: bytes) -> bytes:
    return gzip.compress(text, mtime=0)


BYTE_FINDINGS = [  # (id, new bytes from the old, message)
    ("not_gzip", lambda b: gzip.decompress(b), "not a readable gzip file"),
    ("truncated_gzip", lambda b: b[: len(b) // 2], "not a readable gzip file"),  # not a bare "Aborted."
    ("corrupt_deflate", lambda b: b[:20] + bytes(x ^ 0xFF for x in b[20:40]) + b[40:], "not a readable gzip"),
    ("gzip_of_not_json", lambda b: _gz_text(b"episodes: []"), "not valid JSON"),
    ("gzip_of_not_utf8", lambda b: _gz_text(b'{"episodes": ["\xff"]}'), "not UTF-8"),
    ("gzip_of_a_list", lambda b: _gz_text(b"[]"), "must be a JSON object"),
    ("episodes_not_a_list", lambda b: gz_json({"episodes": 5}), "must be a JSON object"),
]


@pytest.mark.parametrize("name, corrupt, match", BYTE_FINDINGS, ids=[f[0] for f in BYTE_FINDINGS])
def test_unreadable_episode_file_is_one_dataset_error(root, name, corrupt, match):
    _set_file(root, EPISODES, corrupt((root / EPISODES).read_bytes()))
    err = _refused(root, match)
    assert err.source == str(root / EPISODES)


def _episode_edit(path: tuple, value=None, delete: bool = False):
    return _edit(("episodes", 0, *path), value, delete)


EPISODE_FINDINGS = [  # (id, edit of {"episodes": [...]}, message, field)
    (
        "no_start_position",
        _episode_edit(("start_position",), delete=True),
        "required",
        "episodes[0].start_position",
    ),
    ("no_goals", _episode_edit(("goals",), delete=True), "required", "episodes[0].goals"),
    ("no_object_id", _episode_edit(("object_id",), delete=True), "required", "episodes[0].object_id"),
    ("no_info", _episode_edit(("info",), delete=True), "required", "episodes[0].info"),
    ("start_nan", _episode_edit(("start_position", 0), NAN), "finite", "episodes[0].start_position[0]"),
    (
        "start_two_numbers",
        _episode_edit(("start_position",), [1.0, 2.0]),
        "at least 3",
        "episodes[0].start_position",
    ),
    (
        "rotation_a_string",
        _episode_edit(("start_rotation",), "north"),
        "valid list",
        "episodes[0].start_rotation",
    ),
    (
        "rotation_not_unit",
        _episode_edit(("start_rotation",), [0, 0, 0, 0]),
        "unit quaternion",
        "episodes[0].start_rotation",
    ),
    (
        "radius_a_string",
        _episode_edit(("goals", 0, "radius"), "0.85"),
        "valid number",
        "episodes[0].goals[0].radius",
    ),
    ("goals_empty", _episode_edit(("goals",), []), "at least 1", "episodes[0].goals"),
    ("goals_a_dict", _episode_edit(("goals",), {}), "valid list", "episodes[0].goals"),
    (
        "view_point_inf",
        _episode_edit(("goals", 0, "view_points", 0, "agent_state", "position", 1), math.inf),
        "finite",
        "episodes[0].goals[0].view_points[0].agent_state.position[1]",
    ),
    (
        "difficulty_unknown",
        _episode_edit(("info", "difficulty"), "extreme"),
        "easy",
        "episodes[0].info.difficulty",
    ),
    (
        "fallback_a_number",
        _episode_edit(("info", "start_clearance_fallback"), 0),
        "valid boolean",
        "episodes[0].info.start_clearance_fallback",
    ),
    ("episode_a_list", _episode_edit((), None), "valid dictionary", "episodes[0]"),
    (
        "other_scene",
        _episode_edit(("scene_id",), "lab_s150_v0"),
        "in the episode file of scene",
        "episodes[0].scene_id",
    ),
    (
        "unknown_category",
        _episode_edit(("object_category",), "toaster"),
        "not a goal category",
        "episodes[0].object_category",
    ),
    ("fewer_episodes", lambda obj: {"episodes": obj["episodes"][:2]}, "the manifest says 3", "episodes"),
]


@pytest.mark.parametrize("name, edit, match, field", EPISODE_FINDINGS, ids=[f[0] for f in EPISODE_FINDINGS])
def test_malformed_episode_is_one_dataset_error(root, name, edit, match, field):
    obj = _episodes_obj(root)
    if name == "episode_a_list":
        obj["episodes"][0] = list(obj["episodes"][0])
    else:
        obj = edit(obj)
    _set_file(root, EPISODES, gz_json(obj))
    err = _refused(root, match, field)
    assert err.source == str(root / EPISODES)


# --- paths that lead outside the dataset folder ------------------------------------------------------
def _outside_copy(root: Path, rel: str) -> Path:
    """A valid copy of ``rel`` outside the dataset folder (same hash, so only its place is wrong)."""
    out = root.parent / "outside" / Path(rel).name
    out.parent.mkdir(exist_ok=True)
    shutil.copy(root / rel, out)
    return out


@pytest.mark.parametrize("how", ["dotdot", "absolute", "symlink"])
@pytest.mark.parametrize("rel, entry", [(EPISODES, FILE_ENTRY), (SCENE_FILE, ("scenes", "lab_s154_v0"))])
@pytest.mark.parametrize("verify", [True, False])
def test_paths_outside_the_folder_are_refused(root, how, rel, entry, verify):
    outside = _outside_copy(root, rel)
    (root / rel).unlink()
    if how == "dotdot":
        path = f"../outside/{outside.name}"
    elif how == "absolute":
        path = str(outside)
    else:
        path = rel
        (root / rel).symlink_to(outside)
    m = _manifest(root)
    for split in m["splits"].values():  # the view split lists the same file
        for f in split["files"].values():
            if f["file"] == rel:
                f["file"] = path
    if entry[0] == "scenes":
        m["scenes"]["lab_s154_v0"]["file"] = path
    _save_manifest(root, m)
    field = ".".join(entry) + ".file"
    with pytest.raises(DatasetError, match="outside the dataset folder|absolute path") as e:
        ds = EpisodeDataset(root, verify=verify)
        list(ds.episodes("ms_val"))
        ds.spec("lab_s154_v0")
    assert e.value.field == field and e.value.source == str(root / "manifest.json"), str(e.value)


def test_manifest_symlinked_outside_is_refused(root):
    outside = _outside_copy(root, "manifest.json")
    (root / "manifest.json").unlink()
    (root / "manifest.json").symlink_to(outside)
    _refused(root, "symbolic link leading outside the dataset folder")


def test_symlink_inside_the_folder_still_loads(root):
    (root / "ms_val" / "content" / "renamed.json.gz").symlink_to(root / EPISODES)
    m = _manifest(root)
    m["splits"]["ms_val"]["files"]["lab_s154_v0"]["file"] = "ms_val/content/renamed.json.gz"
    _save_manifest(root, m)
    assert len(_load_all(root)["ms_val"]) == 3


# --- limits -------------------------------------------------------------------------------------------
def test_limits_are_the_documented_ones():
    assert dataset.MAX_MANIFEST_BYTES == 16 * 2**20
    assert dataset.MAX_EPISODE_FILE_BYTES == 256 * 2**20
    assert dataset.MAX_EPISODES_PER_SPLIT == 1_000_000
    assert dataset.MAX_JSON_DEPTH == 64
    guide = (Path(__file__).parents[1] / "docs" / "guides" / "datasets.md").read_text()
    section = guide[guide.index("## The dataset folder") :]
    for text in ("16 MiB", "256 MiB", "1,000,000", "64 levels", ".partial-", "one hour"):
        assert text in section, text


def test_oversized_manifest_is_refused(root):
    text = (root / "manifest.json").read_text()
    (root / "manifest.json").write_text(text + " " * (16 * 2**20 - len(text) + 1))
    _refused(root, "more than the limit of 16 MiB")


def test_deeply_nested_manifest_is_refused(root):
    m = _manifest(root)
    m["splits"]["ms_val"]["note"] = "@"
    text = json.dumps(m).replace('"@"', "[" * 100_000 + "]" * 100_000)  # a RecursionError unless caught
    (root / "manifest.json").write_text(text)
    _refused(root, r"nested 100\d{3} levels deep, more than the limit of 64")


def test_deeply_nested_episode_file_is_refused(root):
    obj = _episodes_obj(root)
    text = json.dumps(obj).replace('"episode_id": "0"', '"episode_id": "0", "x": ' + "[" * 65 + "]" * 65)
    _set_file(root, EPISODES, _gz_text(text.encode()))
    _refused(root, "more than the limit of 64")


def test_too_many_episodes_in_a_split_are_refused(root):
    m = _manifest(root)
    for split in ("ms_val", "ms_val_view"):
        m["splits"][split]["episodes"] = 1_000_001
        m["splits"][split]["files"]["lab_s154_v0"]["episodes"] = 1_000_001
    _save_manifest(root, m)
    _refused(root, "more than the limit of 1,000,000 per split", "splits.ms_val.episodes")


def _gzip_bomb(decompressed: int) -> bytes:
    """A valid, empty episode file padded with spaces to ``decompressed`` bytes, compressed ~1000x."""
    z = zlib.compressobj(9, zlib.DEFLATED, 31)  # gzip container
    head, tail = b'{"episodes": [', b"]}"
    parts, pad = [z.compress(head)], decompressed - len(head) - len(tail)
    block = b" " * 2**20
    for _ in range(pad // len(block)):
        parts.append(z.compress(block))
    parts.append(z.compress(b" " * (pad % len(block)) + tail))
    parts.append(z.flush())
    return b"".join(parts)


def test_gzip_bomb_is_not_decompressed_into_memory(root, monkeypatch):
    monkeypatch.setattr(dataset, "MAX_EPISODE_FILE_BYTES", 2**20, raising=False)  # 1 MiB, to test quickly
    bomb = _gzip_bomb(64 * 2**20)
    assert len(bomb) < 2**20
    _set_file(root, EPISODES, bomb)
    ds = EpisodeDataset(root)
    tracemalloc.start()
    try:
        with pytest.raises(DatasetError, match="decompresses to more than the limit of 1 MiB"):
            list(ds.episodes("ms_val"))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 * 2**20, peak


# --- stale build folders --------------------------------------------------------------------------------
def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def _partial(parent: Path, pid: int, age_s: float = 0.0) -> Path:
    d = parent / f".ds.partial-{pid}"
    (d / "scenes").mkdir(parents=True)
    (d / "scenes" / "half.json").write_text("{")
    if age_s:
        t = time.time() - age_s
        os.utime(d, (t, t))
    return d


def test_killed_builds_are_removed_by_the_next_build(tmp_path):
    dead = _partial(tmp_path, _dead_pid())
    old_reused_pid = _partial(tmp_path, 1, age_s=2 * 3600)  # pid 1 runs, but not this build for 2 h
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])  # not pid 1, not us
    young_live_pid = _partial(tmp_path, live.pid)  # a build that may not have taken its lock yet
    other = tmp_path / ".other.partial-123456789"  # another dataset's: not ours to judge
    other.mkdir()
    try:
        write_dataset(tmp_path / "ds", _splits(1), progress=False)
    finally:
        live.kill()
        live.wait()
    assert not dead.exists() and not old_reused_pid.exists()
    assert young_live_pid.exists() and other.exists()
    assert len(_load_all(tmp_path / "ds")["ms_val"]) == 1


def test_a_live_concurrent_build_is_left_alone(tmp_path):
    holder = (
        "import fcntl, os, sys, time\n"
        "d = os.path.join(sys.argv[1], f'.ds.partial-{os.getpid()}')\n"
        "os.mkdir(d)\n"
        "fd = os.open(d, os.O_RDONLY)\n"
        "fcntl.flock(fd, fcntl.LOCK_EX)\n"
        "os.utime(d, (time.time() - 7200, time.time() - 7200))\n"
        "print('locked', flush=True)\n"
        "time.sleep(120)\n"
    )
    p = subprocess.Popen([sys.executable, "-c", holder, str(tmp_path)], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "locked"
        live = tmp_path / f".ds.partial-{p.pid}"
        write_dataset(tmp_path / "ds", _splits(1), progress=False)
        assert live.exists()  # locked: kept, though 2 h old
    finally:
        p.send_signal(signal.SIGKILL)
        p.wait()
    write_dataset(tmp_path / "ds", _splits(1), progress=False)
    assert not live.exists()  # its process was killed: removed


def test_a_build_holds_the_lock_on_its_folder(tmp_path, monkeypatch):
    import fcntl

    from biovln_ms.episodes.generator import EpisodeSampler

    real, seen = EpisodeSampler.episodes, []

    def checking(self, *a, **k):
        (tmp,) = tmp_path.glob(".ds.partial-*")
        fd = os.open(tmp, os.O_RDONLY)
        try:
            with pytest.raises(BlockingIOError):
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        finally:
            os.close(fd)
        seen.append(tmp)
        return real(self, *a, **k)

    monkeypatch.setattr(EpisodeSampler, "episodes", checking)
    write_dataset(tmp_path / "ds", _splits(1), progress=False)
    assert seen and not list(tmp_path.glob(".ds.partial-*"))


# --- the command line -----------------------------------------------------------------------------------
def _truncate(root: Path) -> None:
    _set_file(root, EPISODES, (root / EPISODES).read_bytes()[:-20])


def _list_manifest(root: Path) -> None:
    _save_manifest(root, [_manifest(root)])


def _no_goals(root: Path) -> None:
    obj = _episodes_obj(root)
    del obj["episodes"][1]["goals"]
    _set_file(root, EPISODES, gz_json(obj))


def _traversal(root: Path) -> None:
    outside = _outside_copy(root, EPISODES)
    m = _manifest(root)
    m["splits"]["ms_val"]["files"]["lab_s154_v0"]["file"] = f"../outside/{outside.name}"
    _save_manifest(root, m)


@pytest.mark.parametrize(
    "damage", [_truncate, _list_manifest, _no_goals, _traversal], ids=lambda f: f.__name__
)
def test_cli_prints_one_line_and_exits_2(root, damage):
    damage(root)
    r = subprocess.run(
        [sys.executable, "-m", "biovln_ms.cli", "dataset", "stats", str(root)], capture_output=True, text=True
    )
    assert r.returncode == 2, (r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Aborted" not in r.stderr, r.stderr
    assert "Traceback" not in r.stdout + r.stderr


# --- fuzz: any edit loads correctly or raises DatasetError ---------------------------------------------
MUTANTS = [NAN, math.inf, -math.inf, "x", "", None, True, [], [1.0], {}, 0, -1.0, 1e300]


def _nodes(obj, path: tuple = ()):
    """(path, value) of every node below the root."""
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    for k, v in items:
        yield path + (k,), v
        yield from _nodes(v, path + (k,))


def _mutate(draw, obj):
    """``obj`` with 1-3 random nodes replaced by a mutant value or (dict keys) deleted."""
    obj = copy.deepcopy(obj)
    for _ in range(draw(st.integers(1, 3))):
        nodes = [p for p, _ in _nodes(obj)]
        if not nodes:
            break
        path = draw(st.sampled_from(nodes))
        parent = obj
        for key in path[:-1]:
            parent = parent[key]
        if isinstance(parent, dict) and draw(st.booleans()):
            del parent[path[-1]]
        else:
            parent[path[-1]] = copy.deepcopy(draw(st.sampled_from(MUTANTS)))
    return obj


def _floats(obj):
    if isinstance(obj, float):
        yield obj
    elif isinstance(obj, dict):
        for v in obj.values():
            yield from _floats(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from _floats(v)


@settings(max_examples=int(os.environ.get("BIOVLN_FUZZ_EXAMPLES", 150)), deadline=None)
@given(data=st.data())
def test_damaged_datasets_load_or_raise_dataset_error(base, data):
    kinds = data.draw(st.sets(st.sampled_from(["manifest", "episode", "bytes"]), min_size=1), label="damage")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(shutil.copytree(base, Path(tmp) / "ds"))
        if "episode" in kinds:
            obj = _episodes_obj(root)
            k = data.draw(st.integers(0, len(obj["episodes"]) - 1), label="episode")
            obj["episodes"][k] = _mutate(data.draw, obj["episodes"][k])
            _set_file(root, EPISODES, gz_json(obj))
        if "bytes" in kinds:
            blob = (root / EPISODES).read_bytes()
            text = gzip.decompress(blob)
            cut = data.draw(st.floats(0.0, 1.0), label="cut at")
            how = data.draw(st.sampled_from(["truncated", "not gzip", "garbage", "cut JSON"]), label="bytes")
            if how == "truncated":
                blob = blob[: int(len(blob) * cut)]
            elif how == "not gzip":
                blob = text
            elif how == "garbage":
                blob = data.draw(st.binary(max_size=200), label="garbage")
            else:
                blob = gzip.compress(text[: int(len(text) * cut)], mtime=0)
            _set_file(root, EPISODES, blob)
        if "manifest" in kinds:
            _save_manifest(root, _mutate(data.draw, _manifest(root)))
        try:
            loaded = _load_all(root)
        except DatasetError as e:
            assert "\n" not in str(e)
            event("refused")
            return
        event("loaded")
        for eps in loaded.values():
            assert all(math.isfinite(x) for x in _floats(eps))
