"""Train the detector (``biovln-ms perception train``) on a frame dataset's ``train`` part.

Per-pixel cross-entropy over background + the goal categories, class weights from the training pixels
(inverse square root of each class's frequency, relative to the median, clipped), AdamW with a one-cycle
learning rate, random horizontal flips. The frozen encoder blocks' outputs (``segmenter.FROZEN_BLOCKS``)
are computed once per frame and its mirror image. A tenth of the training groups
(chosen by a hash of the group) is kept aside as validation: its instance precision and recall after each
epoch go into ``train.json`` and the plot; the held-out parts (``test_scenes``, ``test_looks``) are never
read here. After the last epoch the validation frames also choose the operating point: the smallest
instance score (:data:`SCORE_GRID`) whose mean precision and mean recall have the highest harmonic mean;
it goes into the weights' header as ``min_score``. Everything random comes from the seed; the same
seed, data and thread count give the same weights.

Written into ``out`` (each file atomically): ``detector.safetensors`` (see
:mod:`biovln_ms.perception.segmenter`), ``train.json`` (settings, per-step loss, per-epoch validation,
operating points, seconds) and ``train.png`` (loss and validation curves, the chosen point).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from biovln_ms.io_utils import atomic_write_bytes, atomic_write_text, parse_json, save_figure
from biovln_ms.paths import ASSET_DIR
from biovln_ms.perception import segmenter as S
from biovln_ms.perception.frames import FORMAT_VERSION, FramesError, stable_hash
from biovln_ms.perception.matching import Tally, annotated, match_frame

#: share of the training groups kept aside for validation
VAL_SHARE = 0.1
#: class-weight clip (relative to the median class)
WEIGHT_CLIP = (0.05, 10.0)
MAX_FRAMES_READ = 200_000
#: the shipped recipe's passes over the training frames and frames per step (the CLI's defaults)
EPOCHS, BATCH = 20, 16
#: instance scores (mean softmax probability) tried as the operating point on the validation frames
SCORE_GRID = (0.0, 0.4, 0.5, 0.6, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95)
RENDER_FIX = "render the frames again: biovln-ms perception dataset -o DIR"


def read_manifest(folder: Path) -> dict:
    """A frame dataset's manifest, checked against this catalog's goal categories."""
    path = folder / "manifest.json"
    if not path.is_file():
        raise FramesError(
            "not a frame dataset (no manifest.json)",
            source=str(folder),
            fix="render one with: biovln-ms perception dataset -o DIR",
        )
    manifest = parse_json(path.read_bytes(), str(path), "frame manifest", error=FramesError, fix=RENDER_FIX)
    if manifest.get("format_version") != FORMAT_VERSION:
        raise FramesError(
            f"frame format {manifest.get('format_version')!r}, this version reads {FORMAT_VERSION}",
            source=str(path),
            field="format_version",
            fix="render it again with: biovln-ms perception dataset -o DIR",
        )
    if manifest.get("categories") != S.goal_categories():
        raise FramesError(
            "the frames label another catalog's goal categories",
            source=str(path),
            field="categories",
            fix="render frames with this catalog: biovln-ms perception dataset -o DIR",
        )
    return manifest


def read_part(folder: str | Path, part: str, limit: int | None = None) -> tuple[list[dict], dict[int, list]]:
    """The COCO images of ``part`` (at most ``limit``, in id order) and their annotations by image id, of a
    frame dataset :func:`read_manifest` has checked."""
    folder = Path(folder)
    path = folder / "annotations" / f"{part}.json"
    if not path.is_file():
        raise FramesError("annotations missing", source=str(path), fix="render the frames again")
    coco = parse_json(path.read_bytes(), str(path), "COCO annotations", error=FramesError, fix=RENDER_FIX)
    images = sorted(coco["images"], key=lambda im: im["id"])[: limit or MAX_FRAMES_READ]
    anns: dict[int, list] = {im["id"]: [] for im in images}
    for a in coco["annotations"]:
        if a["image_id"] in anns:
            anns[a["image_id"]].append(a)
    return images, anns


def read_frame(folder: Path, image: dict, anns: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """(RGB uint8, semantic labels uint8: 0 background, 1 + category index) of one frame."""
    from PIL import Image

    rgb = np.asarray(Image.open(folder / image["file_name"]).convert("RGB"))
    inst = np.asarray(Image.open(folder / image["instances_file"]))
    lut = np.zeros(int(inst.max()) + 1, np.uint8)
    for a in anns:
        if a["instance"] < len(lut):
            lut[a["instance"]] = a["category_id"]  # COCO ids are 1 + the goal category's index
    return rgb, lut[inst]


def is_validation(image: dict, seed: int) -> bool:
    return stable_hash("validation", seed, image["group"]) % 1000 < VAL_SHARE * 1000


def load_tensors(
    folder: Path,
    images: list[dict],
    anns: dict[int, list],
    progress: bool = False,
    input_size: tuple[int, int] = S.INPUT_SIZE,
):
    """(inputs (N, 3, h, w) float32 normalised, labels (N, h, w) int64) at the net's ``input_size``."""
    import torch
    from tqdm import tqdm

    xs, ys = [], []
    for im in tqdm(images, desc="reading frames", unit="frame", disable=not progress):
        rgb, lab = read_frame(folder, im, anns[im["id"]])
        xs.append(S.prepare(rgb, input_size)[0])
        ys.append(torch.from_numpy(S.nearest(lab, input_size).astype(np.int64)))
    return torch.stack(xs), torch.stack(ys)


def frozen_features(net, x, progress: bool = False, chunk: int = 32):
    """The frozen part's output and taps for every frame and its mirror image, as fp16 tensors indexed
    [flipped, frame]: computed once, as the frozen weights never change."""
    import torch
    from tqdm import tqdm

    net.eval()
    hs, taps = [], []
    with torch.no_grad():
        for flip in (False, True):
            h_parts, tap_parts = [], []
            for i in tqdm(range(0, len(x), chunk), desc="frozen features", disable=not progress):
                xb = x[i : i + chunk]
                h, t = net.features(xb.flip(-1) if flip else xb)
                h_parts.append(h.half())
                tap_parts.append([v.half() for v in t])
            hs.append(torch.cat(h_parts))
            taps.append([torch.cat([p[k] for p in tap_parts]) for k in range(len(tap_parts[0]))])
    return torch.stack(hs), [torch.stack([taps[0][k], taps[1][k]]) for k in range(len(taps[0]))]


def class_weights(labels, n_classes: int):
    import torch

    freq = torch.bincount(labels.ravel(), minlength=n_classes).double()
    freq = freq / freq.sum()
    seen = freq > 0
    med = freq[seen].median()
    w = torch.ones(n_classes, dtype=torch.float64)
    w[seen] = (med / freq[seen]).sqrt()
    return w.clamp(*WEIGHT_CLIP).float()


def train_detector(
    frames: str | Path,
    out: str | Path,
    seed: int = 0,
    epochs: int = EPOCHS,
    batch: int = BATCH,
    lr: float = 2e-3,
    threads: int = 2,
    max_minutes: float | None = None,
    limit: int | None = None,
    progress: bool = False,
    commit: str | None = None,
    input_size: tuple[int, int] = S.INPUT_SIZE,
) -> dict:
    """Train on ``frames`` (a frame dataset folder) and write ``out``; returns the ``train.json`` data.
    ``input_size``: the net's (width, height) (``segmenter.check_input_size``), at most the frames' size.
    ``max_minutes`` stops after the first step past it (the run is then no longer a function of the seed
    alone; ``train.json`` says so). ``limit``: read only the first frames (tests)."""
    import torch
    from tqdm import tqdm

    for name, v, lo, hi in (
        ("epochs", epochs, 1, 1000),
        ("batch", batch, 1, 1024),
        ("threads", threads, 1, 256),
    ):
        if not isinstance(v, int) or not lo <= v <= hi:
            raise FramesError(f"{name} must be a whole number in [{lo}, {hi}], got {v!r}", field=name)
    input_size = S.check_input_size(input_size)
    start = time.monotonic()  # the whole command's time: reading the frames and the frozen features too
    frames, out = Path(frames), Path(out)
    torch.set_num_threads(threads)
    torch.manual_seed(seed)
    manifest = read_manifest(frames)
    framed = (manifest.get("width"), manifest.get("height"))
    if all(isinstance(v, int) for v in framed) and (input_size[0] > framed[0] or input_size[1] > framed[1]):
        raise FramesError(
            f"input size {input_size[0]}x{input_size[1]} is larger than the frames ({framed[0]}x{framed[1]})",
            source=str(frames),
            field="input_size",
            fix="train at most at the frames' size, or render larger ones (perception dataset --frame-size)",
        )
    images, anns = read_part(frames, "train", limit)
    val = [im for im in images if is_validation(im, seed)]
    val_frames = [read_frame(frames, im, anns[im["id"]]) for im in val]  # read once, matched every epoch
    fit = [im for im in images if not is_validation(im, seed)]
    if not fit:
        raise FramesError("no training frames", source=str(frames), fix="render more frames")
    cats = S.goal_categories()
    x, y = load_tensors(frames, fit, anns, progress, input_size)
    weights = class_weights(y, len(cats) + 1)
    net = S.build_net(len(cats) + 1, pretrained=True)
    frozen = {id(p) for m in net.frozen_modules() for p in m.parameters()}
    for m in net.frozen_modules():
        m.requires_grad_(False)
    feats = frozen_features(net, x, progress)
    del x  # only the frozen features are needed from here
    steps_per_epoch = math.ceil(len(fit) / batch)
    trainable = [p for p in net.parameters() if id(p) not in frozen]
    opt = torch.optim.AdamW(trainable, lr=lr, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=lr, total_steps=epochs * steps_per_epoch)
    loss_fn = torch.nn.CrossEntropyLoss(weight=weights)
    gen = torch.Generator().manual_seed(seed)
    losses: list[float] = []
    history: list[dict] = []
    t0, cpu0, stopped = time.monotonic(), time.process_time(), None
    bar = tqdm(total=epochs * steps_per_epoch, desc="training", unit="step", disable=not progress)
    for epoch in range(epochs):
        net.train()
        order = torch.randperm(len(fit), generator=gen)
        for s in range(steps_per_epoch):
            idx = order[s * batch : (s + 1) * batch]
            flip = (torch.rand(len(idx), generator=gen) < 0.5).long()
            h = feats[0][flip, idx].float()
            taps = [t[flip, idx].float() for t in feats[1]]
            yb = torch.where(flip.bool()[:, None, None], y[idx].flip(-1), y[idx])
            logits = torch.nn.functional.interpolate(
                net.logits(h, taps), size=yb.shape[-2:], mode="bilinear", align_corners=False
            )
            loss = loss_fn(logits, yb)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            losses.append(round(loss.item(), 5))
            bar.update(1)
            bar.set_postfix(epoch=epoch + 1, loss=f"{losses[-1]:.3f}")
            if max_minutes is not None and time.monotonic() - t0 > 60 * max_minutes:
                stopped = f"time budget of {max_minutes} min reached in epoch {epoch + 1}, step {s + 1}"
                break
        history.append(
            {
                "epoch": epoch + 1,
                "loss": float(np.mean(losses[-steps_per_epoch:])),
                "seconds": round(time.monotonic() - t0, 1),
            }
        )
        if val:
            found = validation_instances(net, cats, val, val_frames, anns, input_size)
            summary = tally_at(found, cats, 0.0).summary()
            history[-1].update({k: summary[k] for k in ("mean_precision", "mean_recall", "mean_pixel_iou")})
        if stopped:
            break
    bar.close()
    seconds = time.monotonic() - t0
    points = operating_points(found, cats) if val else []  # the last epoch's instances: the final net
    min_score = choose_min_score(points) if points else 0.0
    header = S.header_of(
        cats,
        seed,
        commit,
        {
            "trained_on": {
                "frames": manifest.get("source", ""),
                "frames_seed": manifest.get("seed"),
                "frames_files_sha256": manifest.get("files", {}),
                "train_frames": len(fit),
                "validation_frames": len(val),
            },
            "epochs": len(history),
            "min_score": min_score,
        },
        input_size,
    )
    weights_path = S.save_weights(out / "detector.safetensors", net, header)
    data = {
        "seed": seed,
        "epochs": epochs,
        "epochs_run": len(history),
        "stopped": stopped,
        "batch": batch,
        "lr": lr,
        "threads": threads,
        "input_size": list(input_size),
        "train_frames": len(fit),
        "validation_frames": len(val),
        "class_weights": [round(float(w), 4) for w in weights],
        "parameters": sum(p.numel() for p in net.parameters()),
        "weights_bytes": weights_path.stat().st_size,
        "seconds": round(seconds, 1),
        "cpu_seconds": round(time.process_time() - cpu0, 1),
        "whole_seconds": round(time.monotonic() - start, 1),
        "history": history,
        "min_score": min_score,
        "operating_points": points,
        "loss": losses,
        "header": header,
    }
    atomic_write_text(out / "train.json", json.dumps(data, indent=1) + "\n")
    plot_training(data, out / "train.png")
    return data


def validation_instances(
    net,
    cats: list[str],
    val: list[dict],
    val_frames: list,
    anns: dict,
    input_size: tuple[int, int] = S.INPUT_SIZE,
) -> list:
    """(instances, semantic labels, annotated instances) of each validation frame, every instance kept."""
    net.eval()
    return frame_instances(_InMemorySegmenter(net, cats, input_size), val, val_frames, anns)


def frame_instances(seg, val: list[dict], val_frames: list, anns: dict) -> list:
    """(instances, semantic labels, annotated instances) of each frame as segmenter ``seg`` finds them."""
    return [
        (seg.instances(rgb), lab, annotated(anns[im["id"]], seg.categories, lab.shape))
        for im, (rgb, lab) in zip(val, val_frames)
    ]


def choose_min_score(points: list[dict]) -> float:
    """The operating point: the score of :func:`operating_points` with the best harmonic mean, the
    smallest such score on a tie."""
    return max(points, key=lambda p: (p["f1"], -p["min_score"]))["min_score"]


def tally_at(found: list, cats: list[str], min_score: float) -> Tally:
    """The validation tally of the instances scoring at least ``min_score`` (the segmenter's rule: an
    instance's score, its mean probability, at least the threshold)."""
    tally = Tally(cats)
    for preds, lab, gts in found:
        match_frame(tally, [p for p in preds if p.score >= min_score], gts, cats, lab)
    return tally


def operating_points(found: list, cats: list[str]) -> list[dict]:
    """Mean precision, mean recall and their harmonic mean on the validation frames'
    :func:`validation_instances` for each smallest instance score of :data:`SCORE_GRID`."""
    points = []
    for t in SCORE_GRID:
        s = tally_at(found, cats, t).summary()
        # a category with instances but no detection left counts as precision 0, so a high score cannot
        # look precise by silencing the hard categories
        rows = s["categories"].values()
        prec = [r["precision"] if r["precision"] is not None else 0.0 for r in rows if r["instances"]]
        p, r = round(float(np.mean(prec)), 4) if prec else 0.0, s["mean_recall"] or 0.0
        f1 = 2 * p * r / (p + r) if p + r else 0.0
        points.append({"min_score": t, "mean_precision": p, "mean_recall": r, "f1": round(f1, 4)})
    return points


class _InMemorySegmenter(S.Segmenter):
    """A :class:`~biovln_ms.perception.segmenter.Segmenter` around a net being trained (every instance
    kept: ``min_score`` 0)."""

    def __init__(self, net, categories: list[str], input_size: tuple[int, int] = S.INPUT_SIZE) -> None:
        self.net, self.categories, self.input_size, self.path = net, categories, tuple(input_size), None
        self.header, self.min_score = {}, 0.0


def plot_training(data: dict, path: Path) -> None:
    """Loss per step (and its running mean) beside the validation curves per epoch."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    loss = np.asarray(data["loss"], float)
    a.plot(loss, lw=0.6, alpha=0.5, label="step")
    k = max(1, len(loss) // 30)
    if len(loss) >= k:
        a.plot(np.arange(k - 1, len(loss)), np.convolve(loss, np.ones(k) / k, "valid"), label=f"mean of {k}")
    a.set(xlabel="step", ylabel="cross-entropy", title="training loss", yscale="log")
    a.legend()
    hist = data["history"]
    ep = [h["epoch"] for h in hist]
    for key, label in (
        ("mean_recall", "recall"),
        ("mean_precision", "precision"),
        ("mean_pixel_iou", "pixel IoU"),
    ):
        if all(key in h for h in hist):
            b.plot(ep, [h[key] for h in hist], marker="o", label=label)
    chosen = [p for p in data.get("operating_points", []) if p["min_score"] == data.get("min_score")]
    if chosen and ep:
        for key, colour in (("mean_recall", "C0"), ("mean_precision", "C1")):
            b.plot(ep[-1], chosen[0][key], marker="*", ms=14, color=colour, ls="none")
        b.plot([], [], marker="*", color="grey", ls="none", label=f"at min score {data['min_score']}")
    b.set(
        xlabel="epoch", ylim=(0, 1), title=f"validation ({data['validation_frames']} training-scene frames)"
    )
    b.legend()
    fig.tight_layout()
    save_figure(fig, path)


def install_weights(weights: str | Path) -> Path:
    """Put a weights file (checked first) into the package as the shipped detector and record its SHA-256
    in the assets manifest's ``weights`` (``biovln-ms assets verify`` checks it)."""
    import hashlib

    S.read_weights(weights)
    data = Path(weights).read_bytes()
    target = atomic_write_bytes(S.shipped_weights(), data)
    mpath = ASSET_DIR / "manifest.json"
    manifest = parse_json(mpath.read_bytes(), str(mpath), "assets manifest")
    manifest.setdefault("weights", {})[S.SHIPPED] = hashlib.sha256(data).hexdigest()
    manifest["weights"] = dict(sorted(manifest["weights"].items()))
    atomic_write_text(mpath, json.dumps(manifest, indent=2, sort_keys=True) + "\n")
    return target
