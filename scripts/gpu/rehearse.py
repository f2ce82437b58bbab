"""Rehearse ``scripts/gpu/run_all.sh`` on this CPU machine, as the GPU machine will run it.

    python scripts/gpu/rehearse.py [SECTIONS]      # after scripts/gpu/prepare.sh; default: all sections

Builds ``/tmp/biovln_rehearsal`` (``--root``):

* ``venv/``: a bare virtual environment of this machine's Python (no site packages of the project venv);
* ``image/``: symlinks to the packages of the project venv that the GPU image also has (the device docs'
  list, ``check_closure.DEVICE_HAS``), standing in for the image's site-packages (on ``PYTHONPATH``, last);
* ``wheels/``: ``.whl``'s wheels, the binary ones (cp312) swapped for the same versions built for this
  Python (sapien repacked by the same rules), since cp312 wheels do not install into another Python;
  ``site.tar.xz``: them packed by ``pack_site.sh``, as ``prepare.sh`` packs the GPU machine's;

then runs ``run_all.sh`` with the knobs that point it there (``BIOVLN_WHEELS``, ``BIOVLN_SITE``,
``BIOVLN_SHIM``, ``BIOVLN_GL=none``, ``BIOVLN_GPU_SMOKE=1``: tiny sizes on physx_cpu). What it proves:
the packed site folder unpacks, the import closure of its packages is complete next to the image's
packages, ``biovln_ms`` resolves through the shim without an install, the repacked sapien and mani-skill
run the benchmark, and run_all.sh's plumbing (timeouts, results, logs) works. Versions of the image's
packages are not rehearsed (this venv's are used).
"""

from __future__ import annotations

import argparse
import importlib.metadata as md
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
sys.path.insert(0, str(HERE))

from check_closure import DEVICE_HAS, norm  # noqa: E402
from repack_maniskill import repack  # noqa: E402

CACHE = (
    Path(os.environ.get("BIOVLN_GPU_CACHE", Path.home() / ".cache" / "biovln_ms" / "gpu-wheels"))
    / "rehearsal"
)


def image(site_packages: Path, dest: Path, carried: set[str]) -> list[str]:
    """Symlink the distributions of ``site_packages`` that the GPU image has (and that are not carried),
    with what they need in this venv (another version may need other packages than the image's does:
    huggingface_hub 2 needs httpx2)."""
    from packaging.requirements import Requirement

    dest.mkdir(parents=True)
    dists = {norm(d.metadata["Name"]): d for d in md.distributions(path=[str(site_packages)])}
    todo = [n for n in dists if n in DEVICE_HAS and n not in carried]
    wanted: set[str] = set()
    while todo:
        name = todo.pop()
        if name in wanted or name in carried or name not in dists:
            continue
        wanted.add(name)
        for line in dists[name].requires or []:
            req = Requirement(line)
            if req.marker is None or req.marker.evaluate({"extra": ""}):
                todo.append(norm(req.name))
    linked = []
    for name in sorted(wanted):
        dist = dists[name]
        tops = {Path(str(f)).parts[0] for f in dist.files or []}
        for top in sorted(tops):
            src = site_packages / top
            if top in ("..", "bin") or top.endswith(".pth") or not src.exists():
                continue
            if not (dest / top).exists():
                (dest / top).symlink_to(src)
        linked.append(name)
    return sorted(linked)


def wheels_for_this_python(src: Path, dest: Path) -> None:
    """``src``'s wheels; each cp312 one replaced by the same version for this Python (sapien repacked)."""
    dest.mkdir(parents=True)
    tag = f"cp{sys.version_info.major}{sys.version_info.minor}"
    for w in sorted(src.glob("*.whl")):
        if "-cp312-" not in w.name:
            shutil.copy(w, dest)
            continue
        dist, version = w.name.split("-")[:2]
        version = version.split("+")[0]
        have = [p for p in CACHE.glob(f"{dist}-{version}-{tag}-*.whl")]
        if not have:
            subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "pip",
                    "download",
                    "-q",
                    "--no-deps",
                    "--only-binary=:all:",
                    "-d",
                    str(CACHE),
                    f"{dist}=={version}",
                ],
                check=True,
            )
            have = [p for p in CACHE.glob(f"{dist}-{version}-{tag}-*.whl")]
        if not have:
            raise SystemExit(f"no {tag} wheel of {dist}=={version}")
        if dist.lower() == "sapien":
            repack(have[0], dest)
        else:
            shutil.copy(have[0], dest)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sections", nargs="?", default="")
    ap.add_argument("--root", type=Path, default=Path("/tmp/biovln_rehearsal"))
    ap.add_argument("--budget-s", type=int, default=900)
    args = ap.parse_args()
    root = args.root
    if root.exists():
        shutil.rmtree(root)
    root.mkdir(parents=True)
    subprocess.run([sys.executable, "-m", "venv", str(root / "venv")], check=True)
    carried = set()
    for w in (REPO / ".whl").glob("*.whl"):
        carried.add(norm(re.split(r"-", w.name)[0]))
    if not carried:
        raise SystemExit("no wheels in .whl: run scripts/gpu/prepare.sh first")
    linked = image(Path(sysconfig.get_paths()["purelib"]), root / "image", carried)
    print(f"image stand-in: {len(linked)} packages linked from {sys.prefix}")
    print(f"  beyond the image's list (needed by this venv's versions): {sorted(set(linked) - DEVICE_HAS)}")
    wheels_for_this_python(REPO / ".whl", root / "wheels")
    # packed as prepare.sh packs the GPU machine's (run_all.sh unpacks the archive, as it will there)
    pack = [str(HERE / "pack_site.sh"), str(root / "wheels"), str(root / "site.tar.xz")]
    subprocess.run(["bash", *pack], check=True, env={**os.environ, "PYTHON": sys.executable})
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH", "PYTHONHOME")}
    env.update(
        PYTHON=str(root / "venv" / "bin" / "python"),
        PYTHONPATH=str(root / "image"),
        BIOVLN_WHEELS=str(root / "wheels"),
        BIOVLN_SITE_TAR=str(root / "site.tar.xz"),
        BIOVLN_SITE=str(root / "site"),
        BIOVLN_SHIM=str(root / "shim"),
        BIOVLN_GL="none",
        BIOVLN_GPU_SMOKE="1",
        BIOVLN_GPU_BUDGET_S=str(args.budget_s),
        BIOVLN_DATA_DIR=str(root / "data"),
        OUT=str(root / "out"),
        PATH=f"{root / 'venv' / 'bin'}:{env.get('PATH', '')}",
    )
    cmd = ["bash", str(REPO / "scripts" / "gpu" / "run_all.sh")] + ([args.sections] if args.sections else [])
    rc = subprocess.run(cmd, env=env, cwd=REPO).returncode
    print(f"rehearse: run_all.sh exited {rc}; results in {root / 'out'}")
    sys.exit(rc)


if __name__ == "__main__":
    main()
