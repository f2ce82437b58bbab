"""The CPU-side preparation of the GPU runs: the reproducible wheel repack, the dependency
closure check, the import shim, and benchmarks/gpu_speed.py's bookkeeping. Nothing here needs a GPU, the
network or the carried wheels (``scripts/gpu/prepare.sh`` and ``scripts/gpu/rehearse.py`` exercise
those)."""

from __future__ import annotations

import base64
import csv
import hashlib
import importlib.util
import io
import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
GPU = REPO / "scripts" / "gpu"


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


sys.path.insert(0, str(GPU))
repack_mod = _load("repack_maniskill", GPU / "repack_maniskill.py")
closure = _load("check_closure", GPU / "check_closure.py")
gpu_speed = _load("gpu_speed", REPO / "benchmarks" / "gpu_speed.py")


def make_wheel(path: Path, dist: str, version: str, files: dict[str, bytes], requires=()) -> Path:
    info = f"{dist}-{version}.dist-info"
    meta = f"Metadata-Version: 2.1\nName: {dist}\nVersion: {version}\n" + "".join(
        f"Requires-Dist: {r}\n" for r in requires
    )
    files = {**files, f"{info}/METADATA": meta.encode(), f"{info}/WHEEL": b"Wheel-Version: 1.0\n"}
    whl = path / f"{dist}-{version}-py3-none-any.whl"
    with zipfile.ZipFile(whl, "w") as z:
        for name, data in files.items():
            z.writestr(name, data)
        z.writestr(f"{info}/RECORD", "")
    return whl


MANI = {
    "mani_skill/__init__.py": b"",
    "mani_skill/envs/tasks/tabletop/pick_cube.py": b"# code",
    "mani_skill/assets/robots/panda/panda_v2.urdf": b"<robot/>",
    "mani_skill/assets/robots/panda/franka_description/meshes/visual/link0.glb": b"glb" * 10,
    "mani_skill/assets/robots/fetch/fetch.urdf": b"<robot/>",
    "mani_skill/assets/robots/fetch/meshes/base.STL": b"stl" * 100,
    "mani_skill/assets/environment_maps/default.hdr": b"hdr" * 100,
    "mani_skill/utils/scene_builder/table/assets/table.glb": b"table",
    "mani_skill/utils/scene_builder/replicacad/sky.hdr": b"sky",
    "mani_skill/utils/building/assets/grid_texture.png": b"png",
    "mani_skill/utils/building/assets/floor_tiles_06_diff_2k_aligned.png": b"big png",
}


def test_repack_keeps_code_and_the_traced_assets_only(tmp_path):
    src = make_wheel(tmp_path, "mani_skill", "3.0.1", MANI)
    out, dropped = repack_mod.repack(src, tmp_path / "out")
    assert out.name == "mani_skill-3.0.1+slim-py3-none-any.whl"
    with zipfile.ZipFile(out) as z:
        names = set(z.namelist())
        meta = z.read("mani_skill-3.0.1+slim.dist-info/METADATA").decode()
        record = z.read("mani_skill-3.0.1+slim.dist-info/RECORD").decode()
        note = z.read("mani_skill/REPACKED.txt").decode()
        for row in csv.reader(io.StringIO(record)):  # RECORD is regenerated: every hash matches
            if row[1]:
                digest = base64.urlsafe_b64encode(hashlib.sha256(z.read(row[0])).digest()).rstrip(b"=")
                assert row[1] == "sha256=" + digest.decode() and int(row[2]) == len(z.read(row[0]))
        assert {i.date_time for i in z.infolist()} == {(1980, 1, 1, 0, 0, 0)}
        assert [i.filename for i in z.infolist()] == sorted(
            names, key=lambda n: (n.startswith("mani_skill-3.0.1+slim.dist-info/"), n)
        )
    assert "Version: 3.0.1+slim" in meta
    kept = {n for n in MANI if n in names}
    assert kept == {
        "mani_skill/__init__.py",
        "mani_skill/envs/tasks/tabletop/pick_cube.py",
        "mani_skill/assets/robots/panda/panda_v2.urdf",
        "mani_skill/assets/robots/panda/franka_description/meshes/visual/link0.glb",
        "mani_skill/assets/robots/fetch/fetch.urdf",  # small files stay
        "mani_skill/utils/scene_builder/table/assets/table.glb",
        "mani_skill/utils/building/assets/grid_texture.png",
    }
    assert {n for n, _ in dropped} == set(MANI) - kept
    assert all(n in note for n, _ in dropped)


def test_repack_is_byte_for_byte_reproducible(tmp_path):
    src = make_wheel(tmp_path, "mani_skill", "3.0.1", MANI)
    a, _ = repack_mod.repack(src, tmp_path / "a")
    b, _ = repack_mod.repack(src, tmp_path / "b")
    assert a.read_bytes() == b.read_bytes()
    with pytest.raises(SystemExit, match="already repacked"):
        repack_mod.repack(a, tmp_path / "c")


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")
def test_sapien_rule_replaces_the_denoiser_with_stubs(tmp_path):
    oidn = "sapien/oidn_library/"
    src = make_wheel(
        tmp_path,
        "sapien",
        "3.0.3",
        {
            "sapien/__init__.py": b"",
            "sapien/include/physx/PxPhysics.h": b"// header",
            "sapien/sensor/assets/patterns/d415.png": b"png",
            oidn + "libOpenImageDenoise.so.2.0.1": b"real api",
            oidn + "libOpenImageDenoise_core.so.2.0.1": b"real core" * 1000,
            oidn + "libOpenImageDenoise_device_cuda.so.2.0.1": b"cuda",
            "sapien/vulkan_shader/minimal/camera.frag": b"shader",
        },
    )
    out, _ = repack_mod.repack(src, tmp_path / "out")
    with zipfile.ZipFile(out) as z:
        names = set(z.namelist())
        api = z.read(oidn + "libOpenImageDenoise.so.2.0.1")
        core = z.read(oidn + "libOpenImageDenoise_core.so.2.0.1")
    assert api.startswith(b"\x7fELF") and b"libOpenImageDenoise.so.2" in api and b"oidnNewFilter" in api
    assert core.startswith(b"\x7fELF")
    assert oidn + "libOpenImageDenoise_device_cuda.so.2.0.1" not in names
    assert "sapien/include/physx/PxPhysics.h" not in names
    assert "sapien/sensor/assets/patterns/d415.png" not in names
    assert "sapien/vulkan_shader/minimal/camera.frag" in names


def test_closure_check_classifies_every_requirement(tmp_path, capsys):
    make_wheel(tmp_path, "gymnasium", "1.4.0", {}, ["numpy>=1.21", "farama-notifications>=0.0.1"])
    make_wheel(tmp_path, "farama_notifications", "0.0.6", {})
    make_wheel(
        tmp_path,
        "sapien",
        "3.0.3",
        {},
        [
            "pyperclip",
            "importlib_resources",
            'pywin32; platform_system == "Windows"',
            "pytest; extra == 'dev'",
        ],
    )
    assert closure.check(tmp_path) == 0
    out = capsys.readouterr().out
    assert "carried 0.0.6" in out and "on the machine 2.5.2" in out and "not needed" in out
    assert "pywin32" not in out and "pytest" not in out  # markers for Linux, extras left out

    make_wheel(tmp_path, "trimesh", "5.2.0", {}, ["some-unknown-package"])
    assert closure.check(tmp_path) == 1
    out = capsys.readouterr().out
    assert "some-unknown-package: neither carried nor on the machine" in out


def test_closure_check_refuses_two_versions_of_one_wheel(tmp_path, capsys):
    make_wheel(tmp_path, "dacite", "1.9.2", {})
    (tmp_path / "dacite-1.9.2-py3-none-any.whl").rename(tmp_path / "dacite-1.9.2-py3-none-any.whl.keep")
    make_wheel(tmp_path, "dacite", "1.8.0", {})
    (tmp_path / "dacite-1.9.2-py3-none-any.whl.keep").rename(tmp_path / "dacite-1.9.2-py3-none-any.whl")
    assert closure.check(tmp_path) == 1
    assert "two versions of dacite" in capsys.readouterr().out


def test_the_shim_gives_the_installed_layout_without_an_install(tmp_path):
    subprocess.run(["bash", str(GPU / "shim.sh"), str(tmp_path)], check=True)
    code = (
        "import importlib.util, biovln_ms, biovln_ms.assets; "
        "print(biovln_ms.__file__); print(biovln_ms.assets.__file__); "
        "print(importlib.util.find_spec('biovln_ms.tasks').origin); "
        "print(importlib.util.find_spec('biovln_ms.agents.robots').origin)"
    )
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "PYTHONSAFEPATH": "1"}
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True, check=True
    ).stdout.split()
    shim = str(tmp_path / "biovln_ms")
    assert all(line.startswith(shim) for line in out), out
    assert Path(out[2]).resolve() == REPO / "tasks" / "__init__.py"
    assert Path(out[3]).resolve() == REPO / "agents" / "robots" / "__init__.py"
    assert Path(out[1]).resolve() == REPO / "assets" / "__init__.py"


def test_sections_that_need_physx_gpu_are_marked_blocked_not_run(tmp_path, monkeypatch):
    monkeypatch.setattr(gpu_speed, "physx_gpu_blocker", lambda smoke: "no libPhysXGpu_64.so here")

    def boom(*a, **k):
        raise AssertionError("no env may be made when physx_cuda is blocked")

    monkeypatch.setattr(gpu_speed, "make_nav", boom)
    results = gpu_speed.Results(tmp_path)
    for name in gpu_speed.NEEDS_PHYSX_GPU:
        gpu_speed.run_section(name, results, gpu_speed.Sizes(smoke=False))
    data = json.loads((tmp_path / "gpu_speed.json").read_text())
    assert all(data[n] == {"blocked": "no libPhysXGpu_64.so here"} for n in gpu_speed.NEEDS_PHYSX_GPU)
    md = (tmp_path / "gpu_speed.md").read_text()
    assert md.count("blocked") >= len(gpu_speed.NEEDS_PHYSX_GPU)


def test_a_failing_measurement_leaves_its_error_and_the_others(tmp_path, capsys):
    results = gpu_speed.Results(tmp_path)
    results.put("pickcube", "1024", {"num_envs": 1024, "steps_per_s": 500000.0})
    gpu_speed.guarded(results, "state", "64", lambda: {"num_envs": 64, "steps_per_s": 25000.0})

    def crash():
        raise RuntimeError("PxgCudaMemoryAllocator fail to allocate memory")

    gpu_speed.guarded(results, "state", "1024", crash)
    gpu_speed.main(
        ["--out", str(tmp_path), "--section", "state", "--record-error", "process: timed out after 200 s"]
    )
    data = json.loads((tmp_path / "gpu_speed.json").read_text())
    assert data["state"]["64"]["steps_per_s"] == 25000.0
    assert data["state"]["1024"]["error"].startswith("RuntimeError: PxgCudaMemoryAllocator")
    assert data["state"]["process"] == {"error": "process: timed out after 200 s"}
    md = (tmp_path / "gpu_speed.md").read_text()
    assert "| 64 | 25,000 | 0.05x |" in md
    assert "error: RuntimeError: PxgCudaMemoryAllocator" in md


def test_wheel_list_is_pinned_by_the_constraints():
    names = [line.split("#")[0].strip() for line in (GPU / "wheels.txt").read_text().splitlines()]
    pinned = {
        closure.norm(line.split("==")[0])
        for line in (REPO / "scripts" / "constraints.txt").read_text().splitlines()
        if "==" in line
    }
    assert {"sapien", "mani-skill"} <= {closure.norm(n) for n in names if n}
    assert all(closure.norm(n) in pinned for n in names if n)


def _packs_here() -> bool:
    """pack_site.sh's tools: xz, GNU tar (--sort) and pip in this Python."""
    tar = (
        subprocess.run(["tar", "--version"], capture_output=True, text=True) if shutil.which("tar") else None
    )
    pip = subprocess.run([sys.executable, "-m", "pip", "--version"], capture_output=True)
    return bool(shutil.which("xz") and tar and "GNU tar" in tar.stdout and pip.returncode == 0)


@pytest.mark.skipif(not _packs_here(), reason="needs xz, GNU tar and pip")
def test_packed_site_is_what_pip_installs_and_reproducible(tmp_path):
    """pack_site.sh: the wheels' files as ``pip install --target`` lays them out, with no console scripts
    and no record of where the wheels were, so the same wheels in another folder give the same bytes."""
    import tarfile

    env = {**os.environ, "PYTHON": sys.executable}
    packed = []
    for where in ("a", "b/deeper"):
        wheels = tmp_path / where / "wheels"
        wheels.mkdir(parents=True)
        make_wheel(wheels, "tinypkg", "1.0", {"tinypkg/__init__.py": b"X = 1\n", "tinypkg/data.txt": b"d"})
        out = tmp_path / where / "site.tar.xz"
        subprocess.run(["bash", str(GPU / "pack_site.sh"), str(wheels), str(out)], check=True, env=env)
        packed.append(out)
    assert packed[0].read_bytes() == packed[1].read_bytes()
    with tarfile.open(packed[0]) as t:
        names = {n.removeprefix("./") for n in t.getnames()}
        assert t.extractfile("./tinypkg/__init__.py").read() == b"X = 1\n"
    assert {"tinypkg/__init__.py", "tinypkg/data.txt", "tinypkg-1.0.dist-info/METADATA"} <= names
    assert not any(n == "bin" or n.startswith("bin/") or n.endswith("direct_url.json") for n in names)


def test_slimmed_tree_leaves_docs_tests_and_weights_behind():
    """slim_tree.sh size: what travels without docs/, tests/ and the detector's weights, exactly."""

    def listed_bytes(*paths: str) -> int:
        names = subprocess.run(
            ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard", "--", *paths],
            cwd=REPO,
            capture_output=True,
            check=True,
        ).stdout.split(b"\0")
        return sum((REPO / n.decode()).stat().st_size for n in names if n and (REPO / n.decode()).is_file())

    out = subprocess.run(
        ["bash", str(GPU / "slim_tree.sh"), "size"], capture_output=True, text=True, check=True
    )
    left = listed_bytes("docs", "tests", "assets/perception", "assets/scenes")
    assert left > 0
    assert int(out.stdout.strip()) == listed_bytes(".") - left
