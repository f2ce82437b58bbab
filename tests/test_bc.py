"""Behavioural cloning: the paper's architecture, training on recorded runs, checkpoints, evaluation."""

import pickle

import numpy as np
import pytest
import torch

from biovln_ms.eval.harness import EvalConfig, evaluate, load_records
from biovln_ms.learning.bc import ARCH, BCConfig, BCNet, CheckpointError, load_bc, train_bc
from biovln_ms.learning.resnet import ResNet18


@pytest.fixture(scope="module")
def dataset(held_out_dataset):
    return held_out_dataset(ms_val=4)


def run_ms_val(method: str, tmp, dataset, **kw) -> dict:
    """Evaluate ``method`` on the test dataset's MS VAL at 160 x 120 into ``tmp / "res"``; the summary."""
    return evaluate(
        EvalConfig(method, "ms_val", str(tmp / "res"), dataset, workers=1, camera=(160, 120), **kw),
        progress=False,
    )


@pytest.fixture(scope="module")
def trained(dataset, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bc")
    run_ms_val("oracle", tmp, dataset, record_dir=str(tmp / "rec"))
    result = train_bc(
        [tmp / "rec"],
        tmp / "ckpt",
        BCConfig(max_epochs=2, image_size=32, val_fraction=0.25),
        echo=lambda s: None,
        progress=False,
    )
    return tmp, result


def test_architecture_is_the_papers():
    # torchvision's resnet18 has 11,689,512 parameters, 513,000 of them in its 1000-way fc layer
    assert sum(p.numel() for p in ResNet18().parameters()) == 11_689_512 - 513_000
    net = BCNet()
    assert [m.in_features for m in net.head if isinstance(m, torch.nn.Linear)] == [512 + 4, 128]
    assert net(torch.zeros(2, 3, 64, 64), torch.zeros(2, 4)).shape == (2, 4)


def test_training_writes_checkpoint_curve_and_history(trained):
    tmp, r = trained
    assert r.epochs == 2 and r.stopped_by == "max_epochs" and np.isfinite(r.best_val_loss)
    assert r.train_steps > 0 and r.val_steps > 0
    ck = torch.load(r.checkpoint, weights_only=True)  # only tensors, numbers and strings
    assert ck["arch"] == ARCH
    png = (tmp / "ckpt" / "loss.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    model, cfg, meta = load_bc(r.checkpoint)
    assert cfg.image_size == 32 and meta["frame_size"] == [224, 224] and not model.training


def bc_run(trained, dataset, episodes: int, noise: str = "ideal") -> dict:
    """Evaluate the trained BC checkpoint on the first ``episodes`` of MS VAL; returns the summary."""
    tmp, r = trained
    kwargs = {"checkpoint": str(r.checkpoint)}
    return run_ms_val("bc", tmp, dataset, max_episodes=episodes, method_kwargs=kwargs, noise=noise)


@pytest.mark.slow
def test_bc_is_evaluated_through_the_harness(trained, dataset):
    tmp, _ = trained
    summary = bc_run(trained, dataset, 1)
    recs = load_records(tmp / "res" / "bc" / "ms_val" / "episodes.jsonl")
    assert summary["overall"]["episodes"] == 1 and len(recs) == 1
    assert all(not rec.get("error") and all(a in (0, 1, 2, 3) for a in rec["actions"]) for rec in recs)


def test_bad_checkpoints_are_refused(tmp_path, trained, dataset):
    _, r = trained
    other = tmp_path / "other.pt"
    torch.save({"arch": "someone-elses-net", "state_dict": {}}, other)
    with pytest.raises(CheckpointError, match="another architecture"):
        load_bc(other)
    ck = torch.load(r.checkpoint, weights_only=True)
    ck["state_dict"] = {k: v for k, v in ck["state_dict"].items() if not k.startswith("head.")}
    torch.save(ck, tmp_path / "cut.pt")
    with pytest.raises(CheckpointError, match="do not fit"):
        load_bc(tmp_path / "cut.pt")
    (tmp_path / "pickled.pt").write_bytes(pickle.dumps(object()))
    with pytest.raises(CheckpointError):
        load_bc(tmp_path / "pickled.pt")
    (tmp_path / "junk.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(CheckpointError, match="not a readable torch checkpoint|refused"):
        load_bc(tmp_path / "junk.pt")
    with pytest.raises(CheckpointError, match="needs a checkpoint"):
        evaluate(EvalConfig("bc", "ms_val", str(tmp_path / "res"), dataset, workers=1), progress=False)
    from biovln_ms.errors import BioVLNError

    with pytest.raises(BioVLNError, match="takes no option checkpoint"):
        evaluate(
            EvalConfig(
                "oracle",
                "ms_val",
                str(tmp_path / "res"),
                dataset,
                workers=1,
                method_kwargs={"checkpoint": str(r.checkpoint)},
            ),
            progress=False,
        )


@pytest.mark.slow
def test_bc_runs_without_gps_on_its_own_pose_estimate(trained, dataset):
    tmp, _ = trained
    bc_run(trained, dataset, 1, noise="realistic")
    (rec,) = load_records(tmp / "res" / "bc+realistic" / "ms_val" / "episodes.jsonl")
    assert not rec.get("error")
    stats = rec["policy_stats"]
    assert stats["pose_frame"] == "episode" and len(stats["pose_estimates"]) == len(rec["actions"])
    assert stats["pose_estimates"][0] == [0.0, 0.0, 0.0]  # the episode frame's origin
    assert rec["pose_drift_max"] >= 0.0
