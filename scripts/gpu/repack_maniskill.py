"""Repack the mani-skill (and sapien) wheels without what BioVLN-MS never loads, reproducibly.

    python scripts/gpu/repack_maniskill.py WHEEL [WHEEL ...] --out DIR [--list-dropped FILE]

What travels to a GPU machine must stay under 64 MiB; mani-skill 3.0.1's wheel is 101 MB (robot and scene
assets for other tasks) and sapien 3.0.3's cp312 wheel is 51 MB (a 17 MB ray-tracing denoiser, C++
headers, stereo-sensor patterns). Each output wheel keeps every Python module, every small data file
(URDF/SRDF/JSON/XML/text/fonts) and, of the heavy asset files (meshes, textures, environment maps, the
denoiser), only those in the keep lists below; it is named ``<name>-<version>+slim-...whl`` and carries
the list of what it dropped as ``<pkg>/REPACKED.txt``.

Keep lists (``scripts/gpu/trace_assets.py`` prints the files a run opens; those are a subset of these):

* mani-skill: the Panda of ``PickCube-v1`` (``assets/robots/panda/franka_description/**`` and the
  panda URDF/SRDF kept as small files), its table scene (``utils/scene_builder/table/assets/table.glb``)
  and the ground textures (``utils/building/assets/grid_texture*.png``). BioVLN-MS's own robot and
  scenes ship in this repo and load nothing from mani-skill.
* sapien: everything but ``include/`` (C++ headers), ``sensor/assets/patterns/`` (the active-light stereo
  depth sensor's IR patterns), the macOS ``.dylib`` and Intel Open Image Denoise (``oidn_library/``, 22 MB,
  used only by the ray-tracing shader's denoiser). ``libsvulkan2.so`` links ``libOpenImageDenoise.so.2``
  (12 functions) and ``sapien/_oidn_tricks.py`` preloads it after its core library, so both are replaced
  by stubs built here with ``cc`` (``OIDN_STUB``: same sonames; the functions fail, as a machine without
  the denoiser would): SAPIEN imports and renders with every rasterising shader; asking for the OIDN
  denoiser fails. Without a C compiler the real libraries are kept (21 MB more).

The output is byte-for-byte reproducible: entries sorted, fixed timestamps (1980-01-01), fixed
permissions (0644, 0755 for what was executable), fixed compression, ``RECORD`` regenerated.
"""

from __future__ import annotations

import argparse
import base64
import csv
import fnmatch
import hashlib
import io
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

LOCAL = "slim"
DATE = (1980, 1, 1, 0, 0, 0)
#: suffixes of heavy asset files (lower case): dropped unless a keep pattern matches
HEAVY = {
    ".glb",
    ".gltf",
    ".stl",
    ".dae",
    ".obj",
    ".mtl",
    ".ply",
    ".png",
    ".jpg",
    ".jpeg",
    ".hdr",
    ".exr",
    ".ktx",
    ".ktx2",
    ".npy",
    ".npz",
    ".bin",
    ".dylib",
    ".dll",
}
RULES = {
    "mani_skill": dict(
        keep=[
            "mani_skill/assets/robots/panda/franka_description/*",
            "mani_skill/utils/scene_builder/table/assets/table.glb",
            "mani_skill/utils/building/assets/grid_texture*.png",
        ],
        drop=[],
    ),
    "sapien": dict(
        keep=[],
        drop=[
            "sapien/include/*",
            "sapien/sensor/assets/patterns/*",
        ],
    ),
}


OIDN_DIR = "sapien/oidn_library/"
OIDN_API, OIDN_CORE = "libOpenImageDenoise.so.2.0.1", "libOpenImageDenoise_core.so.2.0.1"
#: what libsvulkan2.so imports from libOpenImageDenoise.so.2 (``readelf --dyn-syms``, sapien 3.0.3)
OIDN_STUB = r"""
/* BioVLN-MS stub of Intel Open Image Denoise 2 for SAPIEN's libsvulkan2.so (denoiser unavailable). */
#include <stddef.h>
static const char *msg = "Open Image Denoise is not installed (BioVLN-MS slim sapien wheel)";
void *oidnNewCUDADevice(const int *ids, const void *streams, int n) { return NULL; }
void oidnCommitDevice(void *d) {}
void oidnReleaseDevice(void *d) {}
int oidnGetDeviceError(void *d, const char **out) { if (out) *out = msg; return 1; }
void *oidnNewSharedBuffer(void *d, void *ptr, size_t size) { return NULL; }
void oidnReleaseBuffer(void *b) {}
void *oidnNewFilter(void *d, const char *type) { return NULL; }
void oidnSetFilterImage(void *f, const char *name, void *b, int fmt, size_t w, size_t h,
                        size_t off, size_t ps, size_t rs) {}
void oidnSetFilterBool(void *f, const char *name, _Bool v) {}
void oidnCommitFilter(void *f) {}
void oidnExecuteFilter(void *f) {}
void oidnReleaseFilter(void *f) {}
"""


def oidn_stubs() -> dict[str, bytes] | None:
    """The stub API and core libraries (file name -> ELF bytes), or None without a C compiler."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        return None
    out = {}
    with tempfile.TemporaryDirectory() as d:
        src = Path(d) / "oidn_stub.c"
        src.write_text(OIDN_STUB)
        empty = Path(d) / "empty.c"
        empty.write_text("/* BioVLN-MS stub of libOpenImageDenoise_core (nothing) */\n")
        for name, soname, c in (
            (OIDN_API, "libOpenImageDenoise.so.2", src),
            (OIDN_CORE, OIDN_CORE, empty),
        ):
            so = Path(d) / name
            flags = ["-shared", "-fPIC", "-O2", "-s", "-nostdlib", "-Wl,--build-id=none"]
            subprocess.run([cc, *flags, f"-Wl,-soname,{soname}", "-o", str(so), str(c)], check=True)
            out[name] = so.read_bytes()
    return out


def _b64(digest: bytes) -> str:
    return base64.urlsafe_b64encode(digest).rstrip(b"=").decode()


def kept(rule: dict, name: str) -> bool:
    if any(fnmatch.fnmatchcase(name, p) for p in rule["drop"]):
        return False
    if Path(name).suffix.lower() not in HEAVY:
        return True
    return any(fnmatch.fnmatchcase(name, p) for p in rule["keep"])


def repack(src: Path, out_dir: Path) -> tuple[Path, list[tuple[str, int]]]:
    """Write the slim wheel of ``src`` into ``out_dir``; returns its path and the dropped (name, size)."""
    m = re.match(r"^([A-Za-z0-9_.]+)-([^-]+)-(.+)\.whl$", src.name)
    if not m:
        raise SystemExit(f"not a wheel file name: {src.name}")
    dist, version, tags = m.groups()
    rule = RULES.get(dist.lower())
    if rule is None:
        raise SystemExit(f"no repack rule for {dist} (known: {', '.join(RULES)})")
    if "+" in version:
        raise SystemExit(f"{src.name} is already repacked")
    new_version = f"{version}+{LOCAL}"
    old_info, new_info = f"{dist}-{version}.dist-info", f"{dist}-{new_version}.dist-info"
    pkg = dist.lower()
    files: dict[str, tuple[bytes, int]] = {}
    dropped: list[tuple[str, int]] = []
    stubs = oidn_stubs() if dist.lower() == "sapien" else None
    with zipfile.ZipFile(src) as z:
        for info in z.infolist():
            name = info.filename
            if name.endswith("/"):
                continue
            if name == f"{old_info}/RECORD":
                continue
            if stubs is not None and name.startswith(OIDN_DIR):
                dropped.append((name, info.file_size))
                stub = stubs.get(name[len(OIDN_DIR) :])
                if stub is not None:  # the same file name, a stub inside
                    files[name] = (stub, 0o755)
                continue
            if not name.startswith(old_info + "/") and not kept(rule, name):
                dropped.append((name, info.file_size))
                continue
            data = z.read(info)
            if name == f"{old_info}/METADATA":
                data = re.sub(rb"(?m)^Version: .*$", f"Version: {new_version}".encode(), data, count=1)
            executable = (info.external_attr >> 16) & 0o111
            if name.startswith(old_info + "/"):
                name = new_info + name[len(old_info) :]
            files[name] = (data, 0o755 if executable else 0o644)
    dropped.sort()
    note = (
        f"Repacked from {src.name} by BioVLN-MS scripts/gpu/repack_maniskill.py for GPU machines:\n"
        f"{len(dropped)} files ({sum(s for _, s in dropped)} bytes) not used by BioVLN-MS were dropped.\n\n"
        + "".join(f"{n}\t{s}\n" for n, s in dropped)
    ).encode()
    files[f"{pkg}/REPACKED.txt"] = (note, 0o644)
    record = io.StringIO()
    w = csv.writer(record, lineterminator="\n")
    for name in sorted(files):
        data = files[name][0]
        w.writerow([name, f"sha256={_b64(hashlib.sha256(data).digest())}", len(data)])
    w.writerow([f"{new_info}/RECORD", "", ""])
    files[f"{new_info}/RECORD"] = (record.getvalue().encode(), 0o644)

    out_dir.mkdir(parents=True, exist_ok=True)
    out = out_dir / f"{dist}-{new_version}-{tags}.whl"
    tmp = out.with_suffix(".tmp")
    # dist-info last, as wheel builders write it
    order = sorted(files, key=lambda n: (n.startswith(new_info + "/"), n))
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as z:
        for name in order:
            data, mode = files[name]
            zi = zipfile.ZipInfo(name, DATE)
            zi.compress_type = zipfile.ZIP_DEFLATED
            zi.external_attr = (0o100000 | mode) << 16
            zi.create_system = 3
            z.writestr(zi, data, compresslevel=9)
    tmp.replace(out)
    return out, dropped


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("wheels", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--list-dropped", type=Path, help="write the dropped files (wheel, name, bytes) here")
    args = ap.parse_args(argv)
    lines = []
    for src in args.wheels:
        out, dropped = repack(src, args.out)
        before, after = src.stat().st_size, out.stat().st_size
        sha = hashlib.sha256(out.read_bytes()).hexdigest()
        print(
            f"{src.name}: {before / 2**20:.1f} MiB -> {out.name}: {after / 2**20:.1f} MiB "
            f"({len(dropped)} files dropped, {sum(s for _, s in dropped) / 2**20:.1f} MiB unpacked) "
            f"sha256 {sha[:16]}"
        )
        lines += [f"{src.name}\t{n}\t{s}\n" for n, s in dropped]
    if args.list_dropped:
        args.list_dropped.write_text("".join(lines))


if __name__ == "__main__":
    main(sys.argv[1:])
