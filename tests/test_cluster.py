"""Ray addresses are checked in one place (biovln_ms.cluster) for evaluation, training and dataset builds."""

from __future__ import annotations

import pytest

from biovln_ms.cluster import ClusterError, check_address, start_ray
from biovln_ms.eval.harness import EvalConfig, check_options
from biovln_ms.learning.rl import RLConfig, train_rl


@pytest.mark.parametrize("address", ["local", "auto", "ray://head.lab:10001", "10.0.0.2:6379"])
def test_good_addresses_pass(address: str) -> None:
    check_address(address)


@pytest.mark.parametrize("address", ["", "http://head:6379", "head", "x\ny:1", 6379, None])
def test_bad_addresses_are_one_line(address: object) -> None:
    with pytest.raises(ClusterError) as e:
        check_address(address)
    assert e.value.field == "ray_address" and "\n" not in str(e.value) and "ray://" in e.value.fix


def test_eval_and_training_refuse_a_bad_address_before_any_work(tmp_path) -> None:
    with pytest.raises(ClusterError):
        check_options(
            EvalConfig(method="oracle", split="ms_val", out=str(tmp_path), ray_address="http://x:1")
        )
    with pytest.raises(ClusterError):
        train_rl(RLConfig(timesteps=8, ray_address="nowhere"), tmp_path / "run")
    assert not (tmp_path / "run" / "model.zip").exists()


def test_a_silent_head_node_is_refused_quickly() -> None:
    pytest.importorskip("ray")
    with pytest.raises(ClusterError) as e:
        start_ray("127.0.0.1:1", num_cpus=1, timeout_s=2)  # port 1: nothing listens
    assert "no Ray head node answers" in str(e.value) and "\n" not in str(e.value)
