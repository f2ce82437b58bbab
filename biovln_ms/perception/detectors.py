"""Object detectors for VLFM: which pixels of this frame show an instance of the target category?

- ``GTSegmentationDetector``: the simulator's ``semantic_category`` sensor (per
  pixel, 1 + the goal category index of the object seen), a perfect detector. Results with it are
  labelled "VLFM (GT detector)": they bound what a perfect Grounding-DINO + SAM stage would give, not
  what the paper's VLM stack gives.
- ``TrainedDetector``: the goal-category segmentation net trained on this project's rendered frames
  (``biovln_ms.perception.segmenter``), its weights shipped in the package; the target's pixels are
  its instances of the target's category.
- ``OwlViTDetector``: an open-vocabulary detector (Hugging Face OWL-ViT / OWLv2) from a local directory;
  its boxes (score >= threshold) become masks over the depth pixels inside them.

The image detectors drop the pixels of their masks that depth places on the floor (:func:`drop_floor`):
a mask that bleeds past an object's outline takes floor at its base, and floor points in VLFM's object
cloud move the free cell it stops at off the operational face. The GT detector's masks hold none.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

import numpy as np

from biovln_ms.constants import FLOOR_HEIGHT
from biovln_ms.perception.detector_specs import GT_NAME, GT_OBS, GT_SPEC, TRAINED_SPEC, parse_spec
from biovln_ms.perception.scorers import PerceptionError, load_local_model
from biovln_ms.perception.segmenter import MIN_PIXELS, Segmenter
from biovln_ms.task_config import TaskSpec


class Detector(Protocol):
    name: str

    def reset(self, task: TaskSpec) -> None:
        """Start an episode of ``task``."""

    def detect(self, obs: dict, target: str) -> np.ndarray:
        """A boolean (H, W) mask of the target's pixels in the head camera frame (all False: not seen)."""


def head_camera(obs: dict) -> dict:
    return obs["sensor_data"]["head"]


def drop_floor(mask: np.ndarray, obs: dict, band: float = FLOOR_HEIGHT) -> np.ndarray:
    """``mask`` without the pixels whose depth point lies within ``band`` of the floor (z = 0 in the
    frame of the head camera's ``extrinsic_cv``: the world's, or the robot base's under a noise preset
    that gives base-frame extrinsics). Pixels without a depth reading stay."""
    v, u = np.nonzero(mask)
    if not len(v):
        return mask
    params = obs.get("sensor_param", {}).get("head", {})
    if "depth" not in head_camera(obs) or not {"intrinsic_cv", "extrinsic_cv"} <= set(params):
        raise PerceptionError(
            "the observation has no head camera depth and parameters, which place a mask's pixels above "
            "the floor",
            field="obs",
            fix="make the env with obs_mode='rgbd' (sensor_param included, as ManiSkill's default)",
        )
    z = _numpy(head_camera(obs)["depth"][0, ..., 0])[v, u].astype(np.float64) / 1000.0
    k, e = _numpy(params["intrinsic_cv"][0]), _numpy(params["extrinsic_cv"][0])
    cam = np.stack([(u - k[0, 2]) * z / k[0, 0], (v - k[1, 2]) * z / k[1, 1], z], axis=-1)
    height = (cam - e[:3, 3]) @ e[:3, 2]  # the world z of R^T (p - t): column 2 of R
    floor = (z > 0) & (height < band)
    out = mask.copy()
    out[v[floor], u[floor]] = False
    return out


class GTSegmentationDetector:
    """The target's pixels are those the ``semantic_category`` sensor labels with its goal category."""

    name = GT_NAME

    def __init__(self, min_pixels: int = MIN_PIXELS) -> None:
        """``min_pixels`` at 640x480 (scaled with the image area) for a detection to count."""
        self.min_pixels = min_pixels
        self.goal_categories: tuple[str, ...] = ()

    def reset(self, task: TaskSpec) -> None:
        """The sensor's labels index ``task.goal_categories``."""
        self.goal_categories = task.goal_categories

    def detect(self, obs: dict, target: str) -> np.ndarray:
        if "semantic_category" not in obs["extra"]:
            raise PerceptionError(
                "the GT detector needs the semantic_category sensor",
                field="obs_mode",
                fix=f"make the env with obs_mode='{GT_OBS}'",
            )
        semantic = _numpy(obs["extra"]["semantic_category"][0, ..., 0])
        mask = semantic == 1 + self.goal_categories.index(target)
        scaled = self.min_pixels * semantic.size / (640 * 480)
        return mask if mask.sum() >= scaled else np.zeros_like(mask)


class TrainedDetector:
    """The target's pixels are the trained segmenter's instances of its category (each at least
    :data:`~biovln_ms.perception.segmenter.MIN_PIXELS` at 640x480, as the GT detector's); ``weights``
    default: the shipped file."""

    def __init__(self, weights: str | Path | None = None, threads: int | None = None) -> None:

        self.segmenter = Segmenter(weights, threads=threads)
        self.name = TRAINED_SPEC if weights is None else f"{TRAINED_SPEC}:{Path(weights).name}"

    def reset(self, task: TaskSpec) -> None:
        """The task's goal categories must be ones the weights know."""
        unknown = sorted(set(task.goal_categories) - set(self.segmenter.categories))
        if unknown:
            raise PerceptionError(
                f"the task's goal categories {', '.join(unknown)} are not the detector's",
                source=str(self.segmenter.path),
                field="categories",
                fix="train weights for this catalog: biovln-ms perception train -o DIR --frame-data FRAMES",
            )

    def detect(self, obs: dict, target: str) -> np.ndarray:
        return drop_floor(self.segmenter.target_mask(_numpy(head_camera(obs)["rgb"][0]), target), obs)


class OwlViTDetector:
    """Open-vocabulary boxes from a local OWL-ViT; the mask is the box (VLFM refines it with SAM)."""

    def __init__(self, model_dir: str | Path, threshold: float = 0.2) -> None:
        model_dir = Path(model_dir)
        self.model, self.processor = load_local_model(
            model_dir, "detector", "OWL-ViT", "AutoModelForZeroShotObjectDetection", "AutoProcessor"
        )
        self.threshold = threshold
        self.name = f"owlvit:{model_dir.name}"

    def reset(self, task: TaskSpec) -> None:
        """Nothing per episode: the prompt is the target's name."""

    def detect(self, obs: dict, target: str) -> np.ndarray:
        import torch

        rgb = head_camera(obs)["rgb"][0].cpu().numpy()
        h, w = rgb.shape[:2]
        inputs = self.processor(text=[[f"a photo of a {target}"]], images=[rgb], return_tensors="pt")
        with torch.inference_mode():
            out = self.model(**inputs)
        res = self.processor.post_process_object_detection(
            out, threshold=self.threshold, target_sizes=torch.tensor([[h, w]])
        )[0]
        mask = np.zeros((h, w), bool)
        for box in res["boxes"].numpy():
            x0, y0, x1, y1 = np.clip(np.round(box).astype(int), 0, [w, h, w, h])
            mask[y0:y1, x0:x1] = True
        return drop_floor(mask, obs)


def _numpy(x) -> np.ndarray:
    return x.cpu().numpy() if hasattr(x, "cpu") else np.asarray(x)


def make_detector(spec: str) -> Detector:
    """``"gt"`` (the simulator's semantic sensor), ``"trained"`` (the shipped weights),
    ``"trained:<weights file>"`` or ``"owlvit:<directory>"``."""
    kind, arg = parse_spec(spec)
    if kind == GT_SPEC:
        return GTSegmentationDetector()
    if kind == TRAINED_SPEC:
        return TrainedDetector(arg)
    return OwlViTDetector(arg)
