"""The method registry: every baseline and learned policy by name, with what it needs from the env and how
reports, paper comparisons and the CLI name it."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path

from biovln_ms.variants import PROTOCOL_ENV, RL_ENV
from biovln_ms.errors import BioVLNError
from biovln_ms.learning.algorithms import SB3_CONTROL_MODES
from biovln_ms.llm.client import LLMConfig
from biovln_ms.perception.detector_specs import (
    DEFAULT_DETECTOR,
    GT_OBS,
    GT_SPEC,
    IMAGE_OBS,
    LABELS,
    TRAINED_SPEC,
    check_spec,
)
from biovln_ms.perception.scorers import check_scorer_spec


@dataclass(frozen=True)
class MethodSpec:
    """One method: how to build and run it, and how reports, paper comparisons and the CLI name it."""

    factory: Callable
    obs_mode: str  # what the policy reads: "none" for privileged oracles, "depth" for the frontier methods
    description: str
    label: str  # display name in tables, plots and help (e.g. "VLFM (GT detector)")
    report_order: int  # position of its rows in the report's tables and plots (ascending)
    paper_key: str | None = None  # its row in the paper's tables (paper.py), None when the paper has none
    privileged: bool = False  # reads the simulator's ground truth (goal, map), not only observations
    preflight: Callable[..., None] | None = None  # called with its kwargs; raises when it cannot run here
    options: tuple[str, ...] = ()  # keyword arguments the method accepts (e.g. "checkpoint")
    env_id: str | None = None  # the env variant it must run on (None: the benchmark env)
    env_kwargs: dict = field(default_factory=dict)  # extra gym.make arguments (e.g. a control mode)
    report_note: str = ""  # why its numbers differ from the paper's, for the report (when it has runs)
    obs_mode_without_gps: str | None = None  # what it reads without GPS+compass, where that differs

    def obs_mode_under(self, gps_compass: bool) -> str:
        """The observation mode it runs with, with GPS+compass or without (its pose estimate may need more,
        as PPO's needs depth)."""
        without = self.obs_mode_without_gps
        return self.obs_mode if gps_compass or without is None else without

    @property
    def recordable(self) -> bool:
        """`biovln-ms record` runs it as is: nothing to preflight (checkpoint, API key), the benchmark env,
        RGB-D at most."""
        return self.preflight is None and self.env_id is None and self.obs_mode in ("none", "depth", "rgbd")


def _llm_preflight(**_) -> None:

    LLMConfig.from_env()


def _bc_preflight(checkpoint: str | None = None, **_) -> None:
    from biovln_ms.learning.bc import CheckpointError, load_bc

    if not checkpoint:
        raise CheckpointError(
            "the bc method needs a checkpoint",
            field="checkpoint",
            fix="pass --checkpoint ckpt/bc.pt (train one with `biovln-ms train bc`)",
        )
    load_bc(checkpoint)


def _language_preflight(parser: str = "rule", **_) -> None:
    """The language agent's parser: the rule parser runs anywhere, the LLM one needs an endpoint."""
    if parser not in ("rule", "llm"):
        raise BioVLNError(f"unknown parser '{parser}'", field="parser", fix="use parser 'rule' or 'llm'")
    if parser == "llm":
        _llm_preflight()


def _image_detector_preflight(detector: str | None = None, scorer: str | None = None, **_) -> None:
    """The detector and scorer specs must build here (the weights' header read, a model folder found)
    before any env is; the GT detector reads a sensor these methods' observation leaves out: it has its
    own method."""
    if detector == GT_SPEC:
        raise BioVLNError(
            "the GT detector is the ablation method, not a detector option",
            field="detector",
            fix="run -m vlfm_gt (or protocol_vlfm_gt), which `biovln-ms eval --detector gt` picks",
        )
    if detector is None or isinstance(detector, str):  # a built detector or scorer object is the caller's
        check_spec(detector or DEFAULT_DETECTOR)
    if scorer is None or isinstance(scorer, str):
        check_scorer_spec(scorer or "default")


_VLFM_OPTIONS = ("detector", "scorer", "detect_every", "score_every", "erode_px", "cluster_eps")
_PROTOCOL_VLFM_OPTIONS = ("detector", "scorer", "detect_every", "score_every")


def _gt_ablation(learned: MethodSpec, description: str, report_order: int, note: str = "") -> MethodSpec:
    """``learned`` (a VLFM method) with the GT detector fixed: the segmentation sensor in its observation,
    no ``detector`` option, its own label and no paper row."""
    return replace(
        learned,
        factory=partial(learned.factory, detector=GT_SPEC),
        obs_mode=GT_OBS,
        description=description,
        label=learned.label.replace(LABELS[TRAINED_SPEC], LABELS[GT_SPEC]),
        report_order=report_order,
        paper_key=None,
        preflight=None,
        options=tuple(o for o in learned.options if o != "detector"),
        report_note=note,
    )


def _lazy(module: str, cls: str, **fixed) -> Callable:
    """A factory of ``<module>.<cls>`` (``module`` a full module path), imported only when a worker builds
    the policy (so the driver never loads torch, SB3 or the perception models)."""

    def factory(**kw):
        return getattr(importlib.import_module(module), cls)(**fixed, **kw)

    return factory


def _sb3_preflight(checkpoint: str | None = None, **_) -> None:
    """A checkpoint is given and is a file, checked in the driver so that no worker starts without one
    (the workers load it: the driver never imports SB3)."""
    if not checkpoint:
        raise BioVLNError(
            "a learned method needs a checkpoint",
            field="checkpoint",
            fix="pass --checkpoint DIR/model.zip (train one with `biovln-ms train ppo`)",
        )
    if not Path(checkpoint).is_file():
        raise BioVLNError(
            "no such checkpoint",
            source=str(checkpoint),
            field="checkpoint",
            fix="pass the model.zip that `biovln-ms train ppo --out DIR` wrote (DIR/model.zip)",
        )


def _sb3_spec(algo: str, control_mode: str, report_order: int) -> MethodSpec:
    return MethodSpec(
        _lazy("biovln_ms.baselines.sb3_policy", "SB3Policy", algo=algo),
        "state",
        f"Stable-Baselines3 {algo.upper()} on the RL variant (--checkpoint)",
        label=algo.upper(),
        report_order=report_order,
        preflight=_sb3_preflight,
        options=("checkpoint", "deterministic"),
        env_id=RL_ENV,
        env_kwargs={"control_mode": control_mode},
        obs_mode_without_gps="depth",  # for its pose estimate (biovln_ms.baselines.sb3_policy)
    )


_VLFM_NOTE = (
    "VLFM here detects with the segmentation net trained on this project's renders (\"VLFM (learned "
    "detector)\", weights shipped, the perception guide) instead of Grounding DINO + SAM, and scores frames "
    "with a packaged-weights scorer instead of BLIP-2/GPT-4o. It stops next to the object's point cloud, "
    "so it fails where the target's visible side is not its operational face, and where its masks' "
    "looser edges add points on an object's far side (the waste bin; the perception guide)."
)
_VLFM_GT_NOTE = (
    "The GT-detector ablation is not compared with the paper: its detector is the simulator's segmentation "
    "(a perfect Grounding-DINO + SAM stage), an upper bound on VLFM's detection. It still fails where the "
    "target's visible side is not its operational face, and stands closer to instruments than the other "
    "methods (lower MCR, higher VRT)."
)
_BC_NOTE = (
    "BC: trained from scratch on the CPU (no ImageNet ResNet-18 weights ship offline; `--pretrained` "
    "takes them when you have them); the paper fine-tuned ImageNet weights at 224 px for up to 500 "
    "epochs on a GPU. The budget of a run is in its `history.json` (the learning guide: the budget of ours). "
    "The benchmark trains it on frontier's recordings of 200 train-split episodes, so that no evaluated "
    "split is trained on; the paper's BC learned from MS DEV and Two-Room; ours never sees the Two-Room "
    "template."
)

# VLFM with the shipped trained detector, and the GT-detector ablation of each
_VLFM = MethodSpec(
    _lazy("biovln_ms.baselines.vlfm", "VLFMPolicy"),
    IMAGE_OBS,
    "frontier + image-text value map + the shipped trained detector",
    label=LABELS[TRAINED_SPEC],
    report_order=60,
    paper_key="VLFM",
    preflight=_image_detector_preflight,
    options=_VLFM_OPTIONS,
    report_note=_VLFM_NOTE,
)
_PROTOCOL_VLFM = MethodSpec(
    _lazy("biovln_ms.baselines.protocol.vlfm", "ProtocolVLFMPolicy"),
    IMAGE_OBS,
    "VLFM, given each sub-goal's category in turn",
    label="Protocol " + LABELS[TRAINED_SPEC],
    report_order=130,
    preflight=_image_detector_preflight,
    options=_PROTOCOL_VLFM_OPTIONS,
    env_id=PROTOCOL_ENV,
)

# The one registry: a shipped method is its policy module plus one entry here; yours, register_method.
METHODS: dict[str, MethodSpec] = {
    "random": MethodSpec(
        _lazy("biovln_ms.baselines.random_policy", "RandomPolicy"),
        "none",
        "uniform forward/left/right, 5 % stop per step",
        label="Random",
        report_order=10,
        paper_key="Random",
    ),
    "oracle": MethodSpec(
        _lazy("biovln_ms.baselines.oracle", "OraclePolicy"),
        "none",
        "exact geodesic path to the snapped goal",
        label="Oracle",
        report_order=20,
        paper_key="Oracle",
        privileged=True,
    ),
    "zone3_oracle": MethodSpec(
        _lazy("biovln_ms.baselines.zone3_oracle", "Zone3OraclePolicy"),
        "none",
        "up to 8 Zone-3 approach points, centroid fallback",
        label="3-Zone Oracle",
        report_order=50,
        paper_key="3-Zone Oracle",
        privileged=True,
    ),
    "frontier": MethodSpec(
        _lazy("biovln_ms.baselines.frontier", "FrontierPolicy"),
        "depth",
        "depth-only occupancy grid, nearest-frontier exploration",
        label="Frontier",
        report_order=30,
        paper_key="Frontier",
    ),
    "llm_frontier": MethodSpec(
        _lazy("biovln_ms.baselines.llm_frontier", "LLMFrontierPolicy"),
        "depth",
        "frontier + LLM choice among near-equidistant frontiers",
        label="LLM-Frontier",
        report_order=40,
        paper_key="LLM-Frontier",
        preflight=_llm_preflight,
    ),
    "vlfm": _VLFM,
    "vlfm_gt": _gt_ablation(
        _VLFM,
        "VLFM with the simulator's segmentation as its detector (the GT ablation)",
        65,
        _VLFM_GT_NOTE,
    ),
    "bc": MethodSpec(
        _lazy("biovln_ms.baselines.bc_policy", "BCPolicy"),
        "rgbd",
        "behavioural cloning: ResNet-18 + 4-d goal vector (--checkpoint)",
        label="BC",
        report_order=70,
        paper_key="BC",
        preflight=_bc_preflight,
        options=("checkpoint", "sample", "seed"),
        report_note=_BC_NOTE,
    ),
    **{algo: _sb3_spec(algo, mode, 80 + 10 * i) for i, (algo, mode) in enumerate(SB3_CONTROL_MODES.items())},
    # lab protocols (BioVLN-Protocol-v0): K ordered goals, a STOP at each
    "protocol_oracle": MethodSpec(
        _lazy("biovln_ms.baselines.protocol.oracle", "ProtocolOraclePolicy"),
        "none",
        "the oracle's shortest path to each sub-goal in turn",
        label="Protocol Oracle",
        report_order=110,
        privileged=True,
        env_id=PROTOCOL_ENV,
    ),
    "protocol_frontier": MethodSpec(
        _lazy("biovln_ms.baselines.protocol.frontier", "ProtocolFrontierPolicy"),
        "depth",
        "frontier, given each sub-goal's position in turn",
        label="Protocol Frontier",
        report_order=120,
        env_id=PROTOCOL_ENV,
    ),
    "protocol_vlfm": _PROTOCOL_VLFM,
    "protocol_vlfm_gt": _gt_ablation(
        _PROTOCOL_VLFM,
        "VLFM on the simulator's segmentation, given each sub-goal's category in turn (the GT ablation)",
        135,
    ),
    "protocol_language": MethodSpec(
        _lazy("biovln_ms.baselines.protocol.language", "ProtocolLanguagePolicy"),
        "depth+segmentation",
        "reads the instruction: parsed targets resolved on its own map (GT detector), frontier machinery",
        label="Protocol Language (GT detector)",
        report_order=140,
        preflight=_language_preflight,
        options=("parser",),
        env_id=PROTOCOL_ENV,
    ),
}


#: the GT-detector ablation of each learned-detector method: ``eval -m vlfm --detector gt`` runs it
GT_ABLATION = {"vlfm": "vlfm_gt", "protocol_vlfm": "protocol_vlfm_gt"}


def register_method(name: str, spec: MethodSpec, override: bool = False) -> MethodSpec:
    """Add a method to the registry (your policy: ``MethodSpec(MyPolicy, "depth", ...)``); it then runs in
    ``biovln-ms eval``, the suite and the report like a shipped one. A taken name is refused unless
    ``override``."""
    if not isinstance(name, str) or not name.isidentifier():
        raise BioVLNError(
            f"method name {name!r} is not an identifier", field="name", fix="use e.g. 'my_policy'"
        )
    if name in METHODS and not override and METHODS[name] != spec:
        raise BioVLNError(
            f"method '{name}' is already registered",
            field="name",
            fix="choose another name, or pass override=True",
        )
    METHODS[name] = spec
    return spec


def report_methods() -> list[str]:
    """The registered methods in report order."""
    return sorted(METHODS, key=lambda m: METHODS[m].report_order)


def method_of_paper_key(key: str) -> str | None:
    """The registered method whose row in the paper's tables is ``key`` (None when none is)."""
    return next((m for m, s in METHODS.items() if s.paper_key == key), None)


def method_spec(name: str, kwargs: dict | None = None) -> MethodSpec:
    """The method's spec; ``kwargs`` (if given) are checked against what it accepts."""
    if name not in METHODS:
        raise BioVLNError(f"unknown method '{name}'", field="method", fix=f"use one of: {', '.join(METHODS)}")
    spec = METHODS[name]
    extra = sorted(set(kwargs or {}) - set(spec.options))
    if extra:
        raise BioVLNError(
            f"method '{name}' takes no option {', '.join(extra)}",
            field=extra[0],
            fix=f"it accepts: {', '.join(spec.options) or 'no options'}",
        )
    return spec
