"""The base-frame camera parameters (biovln_ms.geometry.base_frame): the fused CPU kernel equals torch's
float32 matmul of the float64 transforms bit for bit (the frontier maps depth through them, so a faster
kernel must not move a single bit), and the result is the camera's mount whatever the base's pose."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from biovln_ms.geometry.base_frame import base_transforms, camera_params_in_base_frame


def _torch_path(pose, ext, c2w):
    b2w, w2b = (torch.from_numpy(m).to(torch.float32) for m in base_transforms(pose))
    return ext @ b2w, w2b @ c2w


def _kernel(pose, ext, c2w):
    out = torch.empty(ext.shape), torch.empty(c2w.shape)
    camera_params_in_base_frame(pose, ext.numpy(), c2w.numpy(), out[0].numpy(), out[1].numpy())
    return out


@pytest.mark.parametrize("n", [1, 3, 16])
def test_kernel_equals_the_torch_matmul_bit_for_bit(n):
    rng = np.random.default_rng(n)
    for trial in range(50):
        pose = np.column_stack([rng.uniform(-30, 30, n), rng.uniform(-30, 30, n), rng.uniform(-4, 4, n)])
        if trial % 5 == 0:  # axis-aligned yaws: exact zeros and signed zeros in the transforms
            pose[:, 2] = rng.choice([0.0, np.pi / 2, -np.pi, np.pi, -0.0], n)
        ext = torch.from_numpy(rng.normal(0, 3, (n, 3, 4)).astype(np.float32))
        c2w = torch.from_numpy(rng.normal(0, 3, (n, 4, 4)).astype(np.float32))
        for got, want in zip(_kernel(pose, ext, c2w), _torch_path(pose, ext, c2w)):
            assert np.array_equal(got.numpy().view(np.uint32), want.numpy().view(np.uint32))


def test_strided_inputs_give_the_same_bits():
    rng = np.random.default_rng(7)
    pose = np.column_stack([rng.uniform(-9, 9, 4), rng.uniform(-9, 9, 4), rng.uniform(-4, 4, 4)])
    pose_strided = np.repeat(pose, 2, axis=0)[::2]  # every other row of a bigger array
    ext = torch.from_numpy(rng.normal(0, 3, (4, 4, 3)).astype(np.float32)).transpose(1, 2)
    c2w = torch.from_numpy(rng.normal(0, 3, (4, 4, 4)).astype(np.float32)).transpose(1, 2)
    assert not (ext.is_contiguous() or c2w.is_contiguous() or pose_strided.flags.c_contiguous)
    for got, want in zip(_kernel(pose_strided, ext, c2w), _torch_path(pose, ext, c2w)):
        assert np.array_equal(got.numpy().view(np.uint32), want.numpy().view(np.uint32))


def test_a_mounted_camera_reads_its_mount_whatever_the_pose():
    mount = np.eye(4)
    mount[:3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]  # looking along the base's x axis
    mount[:3, 3] = [0.1, 0.0, 0.88]
    pose = np.array([[3.0, -2.0, 0.7], [-5.5, 4.25, -2.9]])
    b2w, _ = base_transforms(pose)
    cam2world = torch.from_numpy((b2w @ mount).astype(np.float32))
    extrinsic = torch.from_numpy(np.linalg.inv(b2w @ mount)[:, :3].astype(np.float32))
    ext_base, cam2base = _kernel(pose, extrinsic, cam2world)
    for i in range(len(pose)):
        np.testing.assert_allclose(cam2base[i].numpy(), mount, atol=1e-5)
        np.testing.assert_allclose(ext_base[i].numpy(), np.linalg.inv(mount)[:3], atol=1e-5)
