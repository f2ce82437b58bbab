"""Behavioural cloning (appendix "Behavioral Cloning Per-Category Results", Table 17).

Policy: ResNet-18 -> 512-d feature, concatenated with the 4-d agent-centric goal vector, -> 128-d FC +
ReLU -> 4 action logits (softmax at inference). Training: Adam (lr 1e-4, weight decay 1e-5),
cross-entropy, batch 32, random horizontal flips (with the LEFT/RIGHT swap) and +-5 % brightness,
early stopping on the validation loss. Validation holds out whole episodes, never single frames of a
training episode. Checkpoints hold only tensors, numbers and strings, so they load with
``torch.load(weights_only=True)``; they name their architecture so a foreign one is refused.
"""

from __future__ import annotations

import io
import json
import math
import time
import zlib
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import torch
from torch import nn

from biovln_ms.errors import BioVLNError
from biovln_ms.io_utils import atomic_write_bytes, atomic_write_text, save_figure
from biovln_ms.learning.dataset import TrajectoryDataset, Transforms, image_tensor
from biovln_ms.learning.resnet import ResNet18

ARCH = "biovln-bc-resnet18-goal4-v1"
N_ACTIONS = 4
GOAL_DIM = 4


class CheckpointError(BioVLNError):
    """A checkpoint that is not a BioVLN BC checkpoint of this architecture."""


class BCNet(nn.Module):
    """ResNet-18 (512) ⊕ goal (4) -> 128 FC ReLU -> 4 logits."""

    def __init__(self, hidden: int = 128) -> None:
        super().__init__()
        self.encoder = ResNet18()
        self.head = nn.Sequential(
            nn.Linear(ResNet18.feature_dim + GOAL_DIM, hidden),
            nn.ReLU(inplace=True),
            nn.Linear(hidden, N_ACTIONS),
        )

    def forward(self, image: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
        return self.head(torch.cat([self.encoder(image), goal], dim=1))


@dataclass
class BCConfig:
    lr: float = 1e-4
    weight_decay: float = 1e-5
    batch_size: int = 32
    max_epochs: int = 500  # the paper's schedule; early stopping or max_minutes usually ends it first
    patience: int = 50
    val_fraction: float = 0.1  # of the episodes
    image_size: int = 224
    hflip_p: float = 0.5
    brightness: float = 0.05
    position_noise: float = 0.0
    drop_stop: bool = False
    pretrained: str | None = None  # torchvision-layout ResNet-18 state dict (nothing is downloaded)
    max_minutes: float | None = None  # wall-clock budget; training stops after the epoch that passes it
    max_batches_per_epoch: int | None = None
    seed: int = 0
    threads: int | None = None


@dataclass
class BCResult:
    checkpoint: Path
    best_epoch: int
    best_val_loss: float
    epochs: int
    stopped_by: str
    train_steps: int
    val_steps: int
    minutes: float
    history: list[dict] = field(default_factory=list)


def _episode_split(ds: TrajectoryDataset, val_fraction: float, seed: int) -> tuple[list[int], list[int]]:
    """Indices of training and validation steps, split by whole episodes (stable hash of file + member)."""
    keys = sorted({(str(f), off) for _, f, off, _, _ in ds.index})
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(keys))
    n_val = max(1, int(round(val_fraction * len(keys)))) if len(keys) > 1 else 0
    val_keys = {keys[i] for i in order[:n_val]}
    train, val = [], []
    for i, (_, f, off, _, _) in enumerate(ds.index):
        (val if (str(f), off) in val_keys else train).append(i)
    return train, val


def _run_epoch(model, loader, opt, max_batches: int | None) -> tuple[float, float]:
    """Mean cross-entropy and accuracy over ``loader``; trains when ``opt`` is given."""
    model.train(opt is not None)
    total, correct, n = 0.0, 0, 0
    with torch.set_grad_enabled(opt is not None):
        for b, batch in enumerate(loader):
            if max_batches is not None and b >= max_batches:
                break
            logits = model(batch["image"], batch["goal"])
            loss = nn.functional.cross_entropy(logits, batch["action"])
            if opt is not None:
                opt.zero_grad()
                loss.backward()
                opt.step()
            total += loss.item() * len(batch["action"])
            correct += int((logits.argmax(1) == batch["action"]).sum())
            n += len(batch["action"])
    return total / max(n, 1), correct / max(n, 1)


def _save(path: Path, model: BCNet, cfg: BCConfig, meta: dict) -> None:
    buf = io.BytesIO()
    torch.save(
        {
            "arch": ARCH,
            "config": json.dumps(asdict(cfg)),
            "meta": json.dumps(meta),
            "state_dict": model.state_dict(),
        },
        buf,
    )
    atomic_write_bytes(path, buf.getvalue())


def train_bc(
    data: list[str | Path],
    out: str | Path,
    cfg: BCConfig = BCConfig(),
    echo: Callable[[str], None] = print,
    progress: bool = True,
) -> BCResult:
    """Train on recording folders ``data``; writes ``bc.pt`` (best), ``history.json`` and ``loss.png``."""
    from tqdm import tqdm

    out = Path(out)
    if cfg.threads:
        torch.set_num_threads(cfg.threads)
    torch.manual_seed(cfg.seed)
    size = (cfg.image_size, cfg.image_size)
    aug = Transforms(
        size=size, hflip_p=cfg.hflip_p, brightness=cfg.brightness, position_noise=cfg.position_noise
    )
    train_ds = TrajectoryDataset(data, aug, drop_stop=cfg.drop_stop, seed=cfg.seed)
    val_ds = TrajectoryDataset(data, Transforms(size=size), drop_stop=cfg.drop_stop, seed=cfg.seed)
    tr_idx, va_idx = _episode_split(train_ds, cfg.val_fraction, cfg.seed)
    if not va_idx:
        raise BioVLNError(
            f"only {train_ds.successful_episodes} successful episode(s): nothing to validate on",
            source=", ".join(map(str, data)),
            field="val_fraction",
            fix="record more episodes (early stopping needs held-out episodes)",
        )
    g = torch.Generator().manual_seed(cfg.seed)
    train_loader = torch.utils.data.DataLoader(
        torch.utils.data.Subset(train_ds, tr_idx), batch_size=cfg.batch_size, shuffle=True, generator=g
    )
    val_loader = torch.utils.data.DataLoader(
        torch.utils.data.Subset(val_ds, va_idx), batch_size=cfg.batch_size
    )
    model = BCNet()
    if cfg.pretrained:
        model.encoder.load_pretrained(cfg.pretrained)
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    frame_size = train_ds.frame_size()
    echo(
        f"BC: {train_ds.successful_episodes} successful episodes, {len(tr_idx)} training / {len(va_idx)} "
        f"validation steps, {cfg.image_size}px input"
    )
    out.mkdir(parents=True, exist_ok=True)
    ckpt = out / "bc.pt"
    history: list[dict] = []
    best, best_epoch, stale, stopped_by = math.inf, -1, 0, "max_epochs"
    t0 = time.perf_counter()
    bar = tqdm(range(cfg.max_epochs), desc="BC epochs", disable=not progress)
    for epoch in bar:
        tl, ta = _run_epoch(model, train_loader, opt, cfg.max_batches_per_epoch)
        vl, va = _run_epoch(model, val_loader, None, None)
        minutes = (time.perf_counter() - t0) / 60
        history.append(
            {
                "epoch": epoch,
                "train_loss": tl,
                "train_acc": ta,
                "val_loss": vl,
                "val_acc": va,
                "minutes": round(minutes, 3),
            }
        )
        bar.set_postfix(train=f"{tl:.3f}", val=f"{vl:.3f}", acc=f"{va:.2f}")
        if vl < best - 1e-6:
            best, best_epoch, stale = vl, epoch, 0
            _save(
                ckpt,
                model,
                cfg,
                {
                    "epoch": epoch,
                    "val_loss": vl,
                    "frame_size": frame_size,
                    "episodes": train_ds.successful_episodes,
                },
            )
        else:
            stale += 1
        atomic_write_text(out / "history.json", json.dumps(history, indent=1))
        if stale >= cfg.patience:
            stopped_by = f"early stopping (patience {cfg.patience})"
            break
        if cfg.max_minutes is not None and minutes >= cfg.max_minutes:
            stopped_by = f"time budget ({cfg.max_minutes:g} min)"
            break
    plot_history(history, out / "loss.png")
    return BCResult(
        ckpt,
        best_epoch,
        best,
        len(history),
        stopped_by,
        len(tr_idx),
        len(va_idx),
        (time.perf_counter() - t0) / 60,
        history,
    )


def plot_history(history: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ep = [h["epoch"] for h in history]
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.4))
    ax[0].plot(ep, [h["train_loss"] for h in history], label="train")
    ax[0].plot(ep, [h["val_loss"] for h in history], label="validation")
    ax[0].set(xlabel="epoch", ylabel="cross-entropy", title="BC loss")
    ax[1].plot(ep, [h["train_acc"] for h in history], label="train")
    ax[1].plot(ep, [h["val_acc"] for h in history], label="validation")
    ax[1].set(xlabel="epoch", ylabel="action accuracy", title="BC accuracy", ylim=(0, 1))
    for a in ax:
        a.grid(alpha=0.3)
        a.legend()
    fig.tight_layout()
    save_figure(fig, path)


def load_bc(path: str | Path) -> tuple[BCNet, BCConfig, dict]:
    """(model in eval mode, its training config, meta) of a checkpoint written by ``train_bc``."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(
            "no such checkpoint",
            source=str(path),
            field="checkpoint",
            fix="train one: biovln-ms train bc --data DIR --out ckpt/",
        )
    try:
        ck = torch.load(path, map_location="cpu", weights_only=True)
    except (RuntimeError, EOFError, zlib.error, ValueError, OSError) as e:
        raise CheckpointError(
            f"not a readable torch checkpoint ({type(e).__name__})",
            source=str(path),
            field="checkpoint",
            fix="pass the bc.pt written by `biovln-ms train bc`",
        ) from None
    except Exception as e:  # noqa: BLE001 - pickles refused by weights_only raise UnpicklingError subclasses
        raise CheckpointError(
            f"refused to load ({type(e).__name__}: it is not weights-only)",
            source=str(path),
            field="checkpoint",
            fix="pass the bc.pt written by `biovln-ms train bc`",
        ) from None
    if not isinstance(ck, dict) or ck.get("arch") != ARCH:
        found = ck.get("arch") if isinstance(ck, dict) else type(ck).__name__
        raise CheckpointError(
            f"checkpoint of another architecture ({found!r}; this build reads {ARCH!r})",
            source=str(path),
            field="arch",
            fix="retrain with `biovln-ms train bc`",
        )
    missing = [k for k in ("state_dict", "config", "meta") if k not in ck]
    if missing:
        raise CheckpointError(
            f"the checkpoint has no {', '.join(missing)}",
            source=str(path),
            field=missing[0],
            fix="pass the bc.pt written by `biovln-ms train bc`, or retrain",
        )
    try:
        cfg, meta = BCConfig(**json.loads(ck["config"])), json.loads(ck["meta"])
    except (TypeError, ValueError) as e:
        raise CheckpointError(
            f"unreadable training config or meta ({type(e).__name__})",
            source=str(path),
            field="config",
            fix="retrain with `biovln-ms train bc`",
        ) from None
    model = BCNet()
    try:
        model.load_state_dict(ck["state_dict"])
    except (RuntimeError, KeyError, TypeError) as e:
        raise CheckpointError(
            f"weights do not fit the BC network: {str(e).splitlines()[0]}",
            source=str(path),
            field="state_dict",
            fix="retrain with `biovln-ms train bc`",
        ) from None
    model.eval()
    return model, cfg, meta


def preprocess(rgb: np.ndarray, frame_size: tuple[int, int], image_size: int) -> torch.Tensor:
    """A live (H, W, 3) uint8 frame -> the normalised (1, 3, S, S) tensor training saw: resized to the
    recorder's frame size (W, H) first, then to the input size, both bilinear as recorder and dataset do."""
    from PIL import Image

    img = Image.fromarray(rgb)
    if img.size != tuple(frame_size):
        img = img.resize(tuple(frame_size), Image.BILINEAR)
    return image_tensor(img, (image_size, image_size))[None]
